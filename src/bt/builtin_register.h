// How the built-in nodes are registered, shared by their source files (builtin_controls.cc,
// builtin_decorators.cc, builtin_actions.cc). Internal to src/bt/.
#pragma once
#include <functional>
#include <string>
#include <utility>

#include "bt/factory.h"
#include "bt/tree.h"

namespace mm::bt {

/// Registers node type T as `id`; a control node's child count limits, when given, replace its
/// manifest's (-2: as declared).
template <class T>
void addBuiltin(Factory& f, const std::string& id, const std::string& description, int min_children = -2, int max_children = -2) {
  f.registerNodeType<T>(id, description);
  if (min_children != -2) {
    NodeManifest m = f.manifests().at(id);
    m.min_children = min_children;
    m.max_children = max_children;
    f.registerNode(std::move(m));
  }
}

void registerControlNodes(Factory& f);
void registerDecoratorNodes(Factory& f);
void registerActionNodes(Factory& f);

/// One pending timer on the tree's clock (Timeout, Delay, Sleep): started once, it clears itself
/// before its callback runs, and is cancelled when the node cancels it or is destroyed.
class NodeTimer {
 public:
  NodeTimer() = default;
  NodeTimer(const NodeTimer&) = delete;
  NodeTimer& operator=(const NodeTimer&) = delete;
  ~NodeTimer() { cancel(); }
  void start(Tree& tree, unsigned msec, std::function<void()> fn) {
    cancel();
    tree_ = &tree;
    id_ = tree.addTimer(msec / 1000.0, [this, fn = std::move(fn)] {
      id_ = 0;
      fn();
    });
  }
  void cancel() {
    if (id_) tree_->cancelTimer(id_);
    id_ = 0;
  }

 private:
  Tree* tree_ = nullptr;
  int id_ = 0;
};

}  // namespace mm::bt
