#include "bt/tree_node.h"

#include <chrono>

#include "bt/tree.h"

namespace mm::bt {

const char* toString(NodeKind k) {
  switch (k) {
    case NodeKind::kAction: return "Action";
    case NodeKind::kCondition: return "Condition";
    case NodeKind::kControl: return "Control";
    case NodeKind::kDecorator: return "Decorator";
    case NodeKind::kSubTree: return "SubTree";
  }
  return "?";
}

TreeNode::TreeNode(std::string name, NodeConfig config) : name_(std::move(name)), config_(std::move(config)) {}

void TreeNode::notify(NodeStatus prev, NodeStatus now) {
  if (prev != now && config_.tree) config_.tree->notify(*this, prev, now);
}

void TreeNode::setStatus(NodeStatus s) {
  if (s == NodeStatus::kIdle)
    throw RuntimeError("Node [" + name_ + "]: you are not allowed to set manually the status to IDLE. "
                       "If you know what you are doing (?) use resetStatus() instead.");
  const NodeStatus prev = status_;
  status_ = s;
  notify(prev, s);
}

void TreeNode::resetStatus() {
  const NodeStatus prev = status_;
  status_ = NodeStatus::kIdle;
  notify(prev, NodeStatus::kIdle);
}

void TreeNode::emitWakeUpSignal() {
  if (config_.tree) config_.tree->emitWakeUpSignal();
}

// BT.CPP's order: _failureIf, _successIf, _skipIf, _while, evaluated when the node starts (IDLE);
// while RUNNING only _while, which halts the node when false.
std::optional<NodeStatus> TreeNode::checkPreConditions() {
  const ScriptEnv env = scriptEnv();
  for (int k = 0; k < NodeConfig::kPreCount; ++k) {
    const auto& script = config_.pre[k];
    if (!script) continue;
    if (status_ == NodeStatus::kIdle || status_ == NodeStatus::kSkipped) {
      const bool yes = scriptTruth(script->run(env));
      if (yes && k == NodeConfig::kFailureIf) return NodeStatus::kFailure;
      if (yes && k == NodeConfig::kSuccessIf) return NodeStatus::kSuccess;
      if (yes && k == NodeConfig::kSkipIf) return NodeStatus::kSkipped;
      if (!yes && k == NodeConfig::kWhile) return NodeStatus::kSkipped;
    } else if (status_ == NodeStatus::kRunning && k == NodeConfig::kWhile) {
      if (!scriptTruth(script->run(env))) {
        haltNode();
        return NodeStatus::kSkipped;
      }
    }
  }
  return std::nullopt;
}

void TreeNode::checkPostConditions(NodeStatus s) {
  const ScriptEnv env = scriptEnv();
  if (s == NodeStatus::kSuccess && config_.post[NodeConfig::kOnSuccess]) config_.post[NodeConfig::kOnSuccess]->run(env);
  if (s == NodeStatus::kFailure && config_.post[NodeConfig::kOnFailure]) config_.post[NodeConfig::kOnFailure]->run(env);
  if (config_.post[NodeConfig::kPost]) config_.post[NodeConfig::kPost]->run(env);
}

namespace {
thread_local double t_leaf_seconds = 0;
}  // namespace

double leafTickSeconds() { return t_leaf_seconds; }

NodeStatus TreeNode::executeTick() {
  NodeStatus result;
  if (const auto pre = checkPreConditions()) {
    result = *pre;
  } else {
    try {
      if (kind() == NodeKind::kAction || kind() == NodeKind::kCondition) {
        const auto t0 = std::chrono::steady_clock::now();
        result = tick();
        t_leaf_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      } else {
        result = tick();
      }
    } catch (const NodeError&) {
      throw;
    } catch (const std::exception& e) {
      throw NodeError("Exception in node '" + fullPath() + "' [" + registrationId() + "]: " + e.what());
    }
  }
  if (isCompleted(result)) checkPostConditions(result);
  if (result != NodeStatus::kSkipped) setStatus(result);
  return result;
}

void TreeNode::haltNode() {
  halt();
  if (config_.post[NodeConfig::kOnHalted]) config_.post[NodeConfig::kOnHalted]->run(scriptEnv());
}

// ---- kinds -----------------------------------------------------------------------------------

void ControlNode::haltChild(size_t i) {
  TreeNode* c = children_[i];
  if (c->status() == NodeStatus::kRunning) c->haltNode();
  c->resetStatus();
}

void ControlNode::haltChildren() {
  for (size_t i = 0; i < children_.size(); ++i) haltChild(i);
}

void ControlNode::halt() {
  resetChildren();
  resetStatus();
}

void DecoratorNode::haltChild() {
  if (!child_) return;
  if (child_->status() == NodeStatus::kRunning) child_->haltNode();
  child_->resetStatus();
}

void DecoratorNode::halt() {
  resetChild();
  resetStatus();
}

NodeStatus DecoratorNode::executeTick() {
  const NodeStatus s = TreeNode::executeTick();
  if (child_ && isCompleted(child_->status())) child_->resetStatus();
  return s;
}

NodeStatus SyncActionNode::executeTick() {
  const NodeStatus s = TreeNode::executeTick();
  if (s == NodeStatus::kRunning) throw NodeError("SyncActionNode MUST never return RUNNING");
  return s;
}

void StatefulActionNode::halt() {
  if (status() == NodeStatus::kRunning) onHalted();
  resetStatus();
}

NodeStatus StatefulActionNode::tick() {
  const NodeStatus prev = status();
  if (prev == NodeStatus::kIdle || prev == NodeStatus::kRunning) {
    const NodeStatus s = prev == NodeStatus::kIdle ? onStart() : onRunning();
    if (s == NodeStatus::kIdle) throw RuntimeError("StatefulActionNode::onStart() must not return IDLE");
    return s;
  }
  return prev;
}

}  // namespace mm::bt
