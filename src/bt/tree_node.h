// Tree nodes as BT.CPP v4 defines them: executeTick() checks the pre-conditions (_failureIf,
// _successIf, _skipIf from IDLE, _while every tick), calls tick(), runs the post-conditions
// (_onSuccess/_onFailure, then _post) and stores the status (never SKIPPED); haltNode() halts
// and runs _onHalted. The kinds: control (children), decorator (one child), actions (synchronous,
// or stateful: onStart / onRunning / onHalted) and conditions.
#pragma once
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bt/basic.h"
#include "bt/blackboard.h"
#include "bt/script.h"

namespace mm::bt {

class Tree;

enum class NodeKind { kAction, kCondition, kControl, kDecorator, kSubTree };

/// [s] Wall time this thread has spent inside leaf nodes' tick() (actions and conditions: the
/// node library's work and the built-in leaves), for the benchmark's split of a tick's cost.
double leafTickSeconds();
const char* toString(NodeKind k);  ///< "Action", "Condition", "Control", "Decorator", "SubTree"

/// Everything a node gets when the tree is built.
struct NodeConfig {
  Blackboard* blackboard = nullptr;
  const ScriptEnums* enums = nullptr;
  /// Port name -> the text in the XML (a literal or "{key}"), defaults filled in.
  std::map<std::string, std::string> input_ports, output_ports;
  const PortsList* ports = nullptr;  ///< the node type's declaration
  uint16_t uid = 0;
  std::string path;             ///< BT.CPP's fullPath
  std::string registration_id;  ///< the node type
  Tree* tree = nullptr;
  enum Pre { kFailureIf, kSuccessIf, kSkipIf, kWhile, kPreCount };
  enum Post { kOnHalted, kOnFailure, kOnSuccess, kPost, kPostCount };
  std::array<std::optional<Script>, kPreCount> pre;
  std::array<std::optional<Script>, kPostCount> post;
  std::string where;  ///< "file:line" of the element, for messages
};

class TreeNode {
 public:
  TreeNode(std::string name, NodeConfig config);
  virtual ~TreeNode() = default;
  TreeNode(const TreeNode&) = delete;
  TreeNode& operator=(const TreeNode&) = delete;

  virtual NodeKind kind() const = 0;
  /// One tick with the pre- and post-conditions; returns the status (SKIPPED is not stored).
  virtual NodeStatus executeTick();
  /// halt() then the _onHalted script.
  void haltNode();
  /// Stops whatever is running below and goes back to IDLE.
  virtual void halt() = 0;
  void resetStatus();

  NodeStatus status() const { return status_; }
  const std::string& name() const { return name_; }
  const std::string& fullPath() const { return config_.path; }
  uint16_t uid() const { return config_.uid; }
  const std::string& registrationId() const { return config_.registration_id; }
  const NodeConfig& config() const { return config_; }
  virtual std::vector<TreeNode*> children() const { return {}; }

  /// The port's value as T: a literal is converted from text, "{key}" read from the blackboard.
  template <class T>
  Expected<T> getInput(const std::string& port) const {
    auto it = config_.input_ports.find(port);
    if (it == config_.input_ports.end()) {
      if (config_.ports && config_.ports->count(port))
        return Expected<T>::error("getInput() of node '" + fullPath() +
                                  "' failed because nor the manifest or the XML contain the key: [" + port + "]");
      return Expected<T>::error("getInput() of node '" + fullPath() + "' failed because the manifest doesn't contain the key: [" + port + "]");
    }
    if (const auto key = blackboardKey(it->second, port)) {
      const Blackboard::Entry* e = config_.blackboard->getEntry(*key);
      if (!e || e->value.empty())
        return Expected<T>::error("getInput() failed because it was unable to find the key [" + port + "] remapped to [" + *key + "]");
      return anyCast<T>(e->value);
    }
    return anyCast<T>(Any(it->second));
  }
  /// Writes `value` where the port points ("{key}"); an error when it is not a blackboard key.
  template <class T>
  std::optional<std::string> setOutput(const std::string& port, const T& value) {
    auto it = config_.output_ports.find(port);
    if (it == config_.output_ports.end()) return "setOutput(): the port [" + port + "] is not an output of " + fullPath();
    const auto key = blackboardKey(it->second, port);
    if (!key) return std::string("setOutput requires a blackboard pointer. Use {}");
    config_.blackboard->set(*key, toAny(value));
    return std::nullopt;
  }

 protected:
  virtual NodeStatus tick() = 0;
  /// Sets a status other than IDLE (IDLE: resetStatus()); observers see the change.
  void setStatus(NodeStatus s);
  void emitWakeUpSignal();
  Tree& tree() const { return *config_.tree; }
  ScriptEnv scriptEnv() const { return {config_.blackboard, config_.enums}; }

 private:
  std::optional<NodeStatus> checkPreConditions();
  void checkPostConditions(NodeStatus s);
  void notify(NodeStatus prev, NodeStatus now);
  std::string name_;
  NodeConfig config_;
  NodeStatus status_ = NodeStatus::kIdle;
};

class ControlNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeKind kind() const override { return NodeKind::kControl; }
  void addChild(TreeNode* child) { children_.push_back(child); }
  std::vector<TreeNode*> children() const override { return children_; }
  size_t childrenCount() const { return children_.size(); }
  void halt() override;

 protected:
  /// Halts a RUNNING child, then resets it to IDLE.
  void haltChild(size_t i);
  void haltChildren();
  void resetChildren() { haltChildren(); }
  std::vector<TreeNode*> children_;
};

class DecoratorNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeKind kind() const override { return NodeKind::kDecorator; }
  void setChild(TreeNode* child) { child_ = child; }
  TreeNode* child() const { return child_; }
  std::vector<TreeNode*> children() const override { return {child_}; }
  void halt() override;
  NodeStatus executeTick() override;

 protected:
  void haltChild();
  void resetChild() { haltChild(); }
  TreeNode* child_ = nullptr;
};

/// An action that finishes within its tick (never RUNNING).
class SyncActionNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeKind kind() const override { return NodeKind::kAction; }
  NodeStatus executeTick() override;
  void halt() override { resetStatus(); }
};

class ConditionNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeKind kind() const override { return NodeKind::kCondition; }
  void halt() override { resetStatus(); }
};

/// An action that runs over several ticks: onStart() from IDLE, onRunning() while RUNNING,
/// onHalted() when halted while RUNNING.
class StatefulActionNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeKind kind() const override { return NodeKind::kAction; }
  void halt() final;

 protected:
  NodeStatus tick() final;
  virtual NodeStatus onStart() = 0;
  virtual NodeStatus onRunning() = 0;
  virtual void onHalted() = 0;
};

}  // namespace mm::bt
