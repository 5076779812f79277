// BT.CPP v4's built-in nodes: controls, decorators and actions, each family in its own file.
#include "bt/builtin_nodes.h"

#include "bt/builtin_register.h"

namespace mm::bt {

void registerBuiltinNodes(Factory& f) {
  registerControlNodes(f);
  registerDecoratorNodes(f);
  registerActionNodes(f);
}

}  // namespace mm::bt
