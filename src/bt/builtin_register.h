// How the built-in nodes are registered, shared by their source files (builtin_controls.cc,
// builtin_decorators.cc, builtin_actions.cc). Internal to src/bt/.
#pragma once
#include <cstdint>
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

// The key an `entry` port names: "{key}", or the text itself (as BT.CPP reads it). A missing or
// empty port is an error when the tree is built.
inline std::string entryKey(const NodeConfig& config, const std::string& name) {
  const auto it = config.input_ports.find("entry");
  if (it == config.input_ports.end() || it->second.empty()) throw RuntimeError("Missing port 'entry' in " + name);
  const auto key = blackboardKey(it->second, "entry");
  return key ? *key : it->second;
}

// The entry's write count as last seen: true when it moved since (a first look at a written entry
// counts as moved, BT.CPP's ids starting at 0).
class EntryWatch {
 public:
  explicit EntryWatch(std::string key) : key_(std::move(key)) {}
  bool updated(Blackboard& bb) {
    const Blackboard::Entry* e = bb.getEntry(key_);
    if (!e) return false;
    const uint64_t previous = seen_;
    seen_ = e->sequence;
    return previous != seen_;
  }

 private:
  std::string key_;
  uint64_t seen_ = 0;
};

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
