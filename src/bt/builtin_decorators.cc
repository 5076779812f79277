// BT.CPP v4's built-in decorators, written from their documented and observed behaviour (BT.CPP
// 4.10: src/decorators/*; traces compared in tests/bt/).
#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <set>

#include "bt/builtin_register.h"
#include "bt/factory.h"

namespace mm::bt {
namespace {

// ---- decorators ------------------------------------------------------------------------------


// RetryUntilSuccessful (retry on FAILURE) and Repeat (again on SUCCESS).
class Loop : public DecoratorNode {
 public:
  Loop(const std::string& name, const NodeConfig& config, bool repeat)
      : DecoratorNode(name, config), repeat_(repeat) {}
  void halt() override {
    count_ = 0;
    DecoratorNode::halt();
  }

 protected:
  NodeStatus tick() override {
    const char* port = repeat_ ? "num_cycles" : "num_attempts";
    const auto n = getInput<int>(port);
    if (!n) throw RuntimeError(std::string("Missing parameter [") + port + "] in " + (repeat_ ? "RepeatNode" : "RetryNode"));
    int max = *n;
    bool loop = count_ < max || max == -1;
    setStatus(NodeStatus::kRunning);
    const NodeStatus again = repeat_ ? NodeStatus::kSuccess : NodeStatus::kFailure;
    while (loop) {
      const NodeStatus prev = child_->status();
      const NodeStatus s = child_->executeTick();
      if (s == again) {
        ++count_;
        if (!repeat_) max = getInput<int>(port).value();
        loop = count_ < max || max == -1;
        resetChild();
        if (prev == NodeStatus::kIdle && loop) {
          emitWakeUpSignal();
          return NodeStatus::kRunning;
        }
      } else if (s == NodeStatus::kRunning) {
        return s;
      } else if (s == NodeStatus::kSkipped) {
        resetChild();  // the counter stays
        return s;
      } else if (s == NodeStatus::kIdle) {
        throw RuntimeError("[" + name() + "]: A children should not return IDLE");
      } else {  // the other outcome ends the loop
        count_ = 0;
        resetChild();
        return s;
      }
    }
    count_ = 0;
    return repeat_ ? NodeStatus::kSuccess : NodeStatus::kFailure;
  }

 private:
  bool repeat_;
  int count_ = 0;
};
class RetryUntilSuccessful final : public Loop {
 public:
  RetryUntilSuccessful(const std::string& n, const NodeConfig& c) : Loop(n, c, false) {}
  static PortsList providedPorts() {
    return {inputPort<int>("num_attempts", "Execute again a failing child up to N times. Use -1 to create an infinite loop.")};
  }
};
class Repeat final : public Loop {
 public:
  Repeat(const std::string& n, const NodeConfig& c) : Loop(n, c, true) {}
  static PortsList providedPorts() {
    return {inputPort<int>("num_cycles", "Repeat a successful child up to N times. Use -1 to create an infinite loop.")};
  }
};

class Inverter final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus tick() override {
    setStatus(NodeStatus::kRunning);
    const NodeStatus s = child_->executeTick();
    if (s == NodeStatus::kSuccess || s == NodeStatus::kFailure) {
      resetChild();
      return s == NodeStatus::kSuccess ? NodeStatus::kFailure : NodeStatus::kSuccess;
    }
    if (s == NodeStatus::kIdle) throw RuntimeError("[" + name() + "]: A children should not return IDLE");
    return s;
  }
};

template <bool kSuccess>
class Force final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus tick() override {
    setStatus(NodeStatus::kRunning);
    const NodeStatus s = child_->executeTick();
    if (isCompleted(s)) {
      resetChild();
      return kSuccess ? NodeStatus::kSuccess : NodeStatus::kFailure;
    }
    return s;
  }
};

class KeepRunningUntilFailure final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus tick() override {
    setStatus(NodeStatus::kRunning);
    const NodeStatus s = child_->executeTick();
    if (s == NodeStatus::kFailure) {
      resetChild();
      return s;
    }
    if (s == NodeStatus::kSuccess) resetChild();
    return NodeStatus::kRunning;
  }
};

// Timeout: halts a child still running `msec` after it started (on the tree's clock) and fails.
class Timeout final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList providedPorts() {
    return {inputPort<unsigned>("msec", "After a certain amount of time, halt() the child if it is still running.")};
  }
  void halt() override {
    if (started_) {
      started_ = false;
      timer_.cancel();
    }
    DecoratorNode::halt();
  }

 protected:
  NodeStatus tick() override {
    const auto msec = getInput<unsigned>("msec");
    if (!msec) throw RuntimeError("Missing parameter [msec] in TimeoutNode");
    if (!started_) {
      started_ = true;
      setStatus(NodeStatus::kRunning);
      child_halted_ = false;
      if (*msec > 0)
        timer_.start(tree(), *msec, [this] {
          if (child_->status() == NodeStatus::kRunning) {
            child_halted_ = true;
            haltChild();
            emitWakeUpSignal();
          }
        });
    }
    if (child_halted_) {
      started_ = false;
      return NodeStatus::kFailure;
    }
    const NodeStatus s = child_->executeTick();
    if (isCompleted(s)) {
      started_ = false;
      timer_.cancel();
      resetChild();
    }
    return s;
  }

 private:
  bool started_ = false, child_halted_ = false;
  NodeTimer timer_;
};

// Delay: RUNNING for `delay_msec` (on the tree's clock), then the child.
class Delay final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList providedPorts() {
    return {inputPort<unsigned>("delay_msec", "Tick the child after a few milliseconds")};
  }
  void halt() override {
    started_ = false;
    timer_.cancel();
    DecoratorNode::halt();
  }

 protected:
  NodeStatus tick() override {
    const auto msec = getInput<unsigned>("delay_msec");
    if (!msec) throw RuntimeError("Missing parameter [delay_msec] in DelayNode");
    if (!started_) {
      complete_ = false;
      started_ = true;
      setStatus(NodeStatus::kRunning);
      timer_.start(tree(), *msec, [this] {
        complete_ = true;
        emitWakeUpSignal();
      });
    }
    if (!complete_) return NodeStatus::kRunning;
    const NodeStatus s = child_->executeTick();
    if (isCompleted(s)) {
      started_ = false;
      resetChild();
    }
    return s;
  }

 private:
  bool started_ = false, complete_ = false;
  NodeTimer timer_;
};

class RunOnce final : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList providedPorts() {
    return {inputPort<bool>("then_skip", "true",
                            "If true, skip after the first execution, otherwise return the same NodeStatus returned once by the child.")};
  }

 protected:
  NodeStatus tick() override {
    bool skip = true;
    if (const auto v = getInput<bool>("then_skip")) skip = *v;
    if (done_) return skip ? NodeStatus::kSkipped : returned_;
    setStatus(NodeStatus::kRunning);
    const NodeStatus s = child_->executeTick();
    if (isCompleted(s)) {
      done_ = true;
      returned_ = s;
      resetChild();
    }
    return s;
  }

 private:
  bool done_ = false;
  NodeStatus returned_ = NodeStatus::kIdle;
};

// Precondition: ticks the child while `if` holds (checked only while the child is not running),
// else returns `else`. One extension over BT.CPP 4.10: an `if` read from the blackboard ("{ok}",
// as the source's ExecuteGrasp tree writes it) is parsed when the node is ticked, not when it is
// built; BT.CPP parses it in the constructor, finds the entry still empty and refuses the tree
// ("Missing parameter [if] in Precondition").
class Precondition final : public DecoratorNode {
 public:
  Precondition(const std::string& name, const NodeConfig& config) : DecoratorNode(name, config) {
    if (!blackboardKey(config.input_ports.at("if"), "if")) load();
  }
  static PortsList providedPorts() {
    return {inputPort<std::string>("if", ""),
            inputPort<NodeStatus>("else", "FAILURE", "Return status if condition is false")};
  }

 protected:
  NodeStatus tick() override {
    load();
    const auto otherwise = getInput<NodeStatus>("else");
    if (!otherwise) throw RuntimeError("Missing parameter [else] in Precondition");
    running_ = running_ || scriptTruth(script_->run(scriptEnv()));
    if (!running_) return *otherwise;
    const NodeStatus s = child_->executeTick();
    if (isCompleted(s)) {
      resetChild();
      running_ = false;
    }
    return s;
  }

 private:
  void load() {
    const auto code = getInput<std::string>("if");
    if (!code) throw RuntimeError("Missing parameter [if] in Precondition");
    if (script_ && script_->code() == *code) return;
    script_ = Script::parse(*code);
  }
  std::optional<Script> script_;
  bool running_ = false;  // as BT.CPP: not cleared by a halt
};

}  // namespace

void registerDecoratorNodes(Factory& f) {
  addBuiltin<RetryUntilSuccessful>(f, "RetryUntilSuccessful", "ticks a failing child again, up to num_attempts times");
  addBuiltin<Repeat>(f, "Repeat", "ticks a succeeding child again, num_cycles times");
  addBuiltin<Inverter>(f, "Inverter", "SUCCESS <-> FAILURE");
  addBuiltin<Force<true>>(f, "ForceSuccess", "SUCCESS whenever the child completes");
  addBuiltin<Force<false>>(f, "ForceFailure", "FAILURE whenever the child completes");
  addBuiltin<KeepRunningUntilFailure>(f, "KeepRunningUntilFailure", "RUNNING until the child fails");
  addBuiltin<Timeout>(f, "Timeout", "halts the child after msec and fails");
  addBuiltin<Delay>(f, "Delay", "waits delay_msec, then ticks the child");
  addBuiltin<RunOnce>(f, "RunOnce", "ticks the child once in the tree's life");
  addBuiltin<Precondition>(f, "Precondition", "ticks the child while the script holds, else returns else");
}

}  // namespace mm::bt
