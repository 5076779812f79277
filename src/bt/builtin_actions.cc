// BT.CPP v4's built-in actions, written from their documented and observed behaviour (BT.CPP
// 4.10: src/actions/*; traces compared in tests/bt/).
#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <set>

#include "bt/builtin_register.h"
#include "bt/factory.h"

namespace mm::bt {
namespace {

// ---- actions ---------------------------------------------------------------------------------

class AlwaysSuccess final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus tick() override { return NodeStatus::kSuccess; }
};
class AlwaysFailure final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus tick() override { return NodeStatus::kFailure; }
};

class SetBlackboard final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList providedPorts() {
    auto value = inputPort<AnyTypeAllowed>("value", "Value to be written into the output_key");
    auto key = bidirectionalPort<AnyTypeAllowed>("output_key", "Name of the blackboard entry where the value should be written");
    return {value, key};
  }

 protected:
  NodeStatus tick() override {
    const auto out_key = getInput<std::string>("output_key");
    if (!out_key) throw RuntimeError("missing port [output_key]");
    Blackboard& bb = *config().blackboard;
    const std::string& value_text = config().input_ports.at("value");
    Blackboard::Entry* dst = bb.getEntry(*out_key);
    Any value;
    if (const auto src_key = blackboardKey(value_text, "value")) {
      const Blackboard::Entry* src = bb.getEntry(*src_key);
      if (!src) throw RuntimeError("Can't find the port referred by [value]");
      if (!dst) dst = bb.createEntry(*out_key, src->info);
      value = src->value;
    } else {
      value = Any(value_text);
    }
    if (value.empty()) return NodeStatus::kFailure;
    if (dst && dst->info.stronglyTyped() && dst->info.name != "std::string" && value.isString()) {
      if (!dst->info.parse) throw RuntimeError("Can't convert string [" + value.string() + "] to type [" + dst->info.name + "]");
      try {
        value = dst->info.parse(value.string());
      } catch (const std::exception& e) {
        throw RuntimeError("Can't convert string [" + value.string() + "] to type [" + dst->info.name + "]: " + e.what());
      }
    }
    bb.set(*out_key, value);
    return NodeStatus::kSuccess;
  }
};

class UnsetBlackboard final : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;
  static PortsList providedPorts() { return {inputPort<std::string>("key", "Key of the entry to remove")}; }

 protected:
  NodeStatus tick() override {
    const auto key = getInput<std::string>("key");
    if (!key) throw RuntimeError("missing input port [key]");
    config().blackboard->unset(*key);
    return NodeStatus::kSuccess;
  }
};

// Sleep: RUNNING for `msec` on the tree's clock.
class Sleep final : public StatefulActionNode {
 public:
  using StatefulActionNode::StatefulActionNode;
  static PortsList providedPorts() { return {inputPort<unsigned>("msec", "")}; }

 protected:
  NodeStatus onStart() override {
    const auto msec = getInput<unsigned>("msec");
    if (!msec) throw RuntimeError("Missing parameter [msec] in SleepNode");
    if (*msec == 0) return NodeStatus::kSuccess;
    setStatus(NodeStatus::kRunning);
    waiting_ = true;
    timer_.start(tree(), *msec, [this] {
      waiting_ = false;
      emitWakeUpSignal();
    });
    return NodeStatus::kRunning;
  }
  NodeStatus onRunning() override { return waiting_ ? NodeStatus::kRunning : NodeStatus::kSuccess; }
  void onHalted() override {
    waiting_ = false;
    timer_.cancel();
  }

 private:
  bool waiting_ = false;
  NodeTimer timer_;
};

// Script and ScriptCondition: the code parsed when the tree is built.
class ScriptAction final : public SyncActionNode {
 public:
  ScriptAction(const std::string& name, const NodeConfig& config) : SyncActionNode(name, config) { load(); }
  static PortsList providedPorts() { return {inputPort<std::string>("code", "Piece of code that can be parsed")}; }

 protected:
  NodeStatus tick() override {
    load();
    script_->run(scriptEnv());
    return NodeStatus::kSuccess;
  }

 private:
  void load() {
    const auto code = getInput<std::string>("code");
    if (!code) throw RuntimeError("Missing port [code] in Script");
    if (!script_ || script_->code() != *code) script_ = Script::parse(*code);
  }
  std::optional<Script> script_;
};

class ScriptCondition final : public ConditionNode {
 public:
  ScriptCondition(const std::string& name, const NodeConfig& config) : ConditionNode(name, config) { load(); }
  static PortsList providedPorts() {
    return {inputPort<AnyTypeAllowed>("code", "Piece of code that can be parsed. Must return false or true")};
  }

 protected:
  NodeStatus tick() override {
    load();
    return scriptTruth(script_->run(scriptEnv())) ? NodeStatus::kSuccess : NodeStatus::kFailure;
  }

 private:
  void load() {
    const auto code = getInput<std::string>("code");
    if (!code) throw RuntimeError("Missing port [code] in ScriptCondition");
    if (!script_ || script_->code() != *code) script_ = Script::parse(*code);
  }
  std::optional<Script> script_;
};

// WasEntryUpdated: SUCCESS when the entry was written since this node last looked, else FAILURE
// (a missing entry: FAILURE).
class WasEntryUpdated final : public SyncActionNode {
 public:
  WasEntryUpdated(const std::string& name, const NodeConfig& config) : SyncActionNode(name, config), watch_(entryKey(config, name)) {}
  static PortsList providedPorts() { return {inputPort<AnyTypeAllowed>("entry", "Entry to check")}; }

 protected:
  NodeStatus tick() override { return watch_.updated(*config().blackboard) ? NodeStatus::kSuccess : NodeStatus::kFailure; }

 private:
  EntryWatch watch_;
};

}  // namespace

void registerActionNodes(Factory& f) {
  addBuiltin<WasEntryUpdated>(f, "WasEntryUpdated", "SUCCESS when entry was written since the node last looked, else FAILURE");
  addBuiltin<AlwaysSuccess>(f, "AlwaysSuccess", "SUCCESS");
  addBuiltin<AlwaysFailure>(f, "AlwaysFailure", "FAILURE");
  addBuiltin<SetBlackboard>(f, "SetBlackboard", "writes value into output_key");
  addBuiltin<UnsetBlackboard>(f, "UnsetBlackboard", "removes key");
  addBuiltin<Sleep>(f, "Sleep", "RUNNING for msec");
  addBuiltin<ScriptAction>(f, "Script", "runs code");
  addBuiltin<ScriptCondition>(f, "ScriptCondition", "runs code; SUCCESS if true");
}

}  // namespace mm::bt
