// Registers BT.CPP's built-in nodes (controls, decorators, actions) in a factory.
#pragma once

namespace mm::bt {
class Factory;
void registerBuiltinNodes(Factory& factory);
}  // namespace mm::bt
