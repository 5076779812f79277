// BT.CPP v4's built-in decorators, written from their documented and observed behaviour (BT.CPP
// 4.10: src/decorators/*; traces compared in tests/bt/).
#include <any>
#include <charconv>
#include <cmath>
#include <deque>
#include <memory>
#include <type_traits>
#include <typeinfo>
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

// ---- loops over a queue ------------------------------------------------------------------------

template <class T>
using SharedQueue = std::shared_ptr<std::deque<T>>;

template <class T>
T parseItem(const std::string& s) {
  if constexpr (std::is_same_v<T, int>) return static_cast<int>(parseInteger(s, std::numeric_limits<int>::min(), std::numeric_limits<int>::max()));
  else if constexpr (std::is_same_v<T, bool>) return parseBool(s);
  else if constexpr (std::is_same_v<T, double>) return parseReal(s);
  else return s;
}

// "a;b;c" as BT.CPP splits it: items between the semicolons, a trailing one ends the list.
template <class T>
SharedQueue<T> parseQueue(const std::string& text) {
  auto q = std::make_shared<std::deque<T>>();
  for (size_t pos = 0; pos < text.size();) {
    size_t end = text.find(';', pos);
    if (end == std::string::npos) end = text.size();
    q->push_back(parseItem<T>(text.substr(pos, end - pos)));
    pos = end + 1;
  }
  return q;
}

// LoopInt, LoopBool, LoopDouble, LoopString: pops the front of `queue` into `value` and ticks the
// child, once a tick, while the queue has items; FAILURE when the child fails; `if_empty` when the
// queue is empty with the child not running. The queue is a literal ("1;2;3", copied afresh each
// time the node starts), or a blackboard entry: a queue (popped in place, as BT.CPP shares it), a
// vector or a string (converted when the node starts, then popped from the copy).
template <class T>
class LoopNode final : public DecoratorNode {
 public:
  LoopNode(const std::string& name, const NodeConfig& config) : DecoratorNode(name, config) {
    const auto it = config.input_ports.find("queue");
    if (it != config.input_ports.end() && !blackboardKey(it->second, "queue")) static_queue_ = parseQueue<T>(it->second);
  }
  static PortsList providedPorts() {
    return {bidirectionalPort<AnyTypeAllowed>("queue", ""),
            inputPort<NodeStatus>("if_empty", "SUCCESS", "Status to return if queue is empty: SUCCESS, FAILURE, SKIPPED"),
            outputPort<T>("value", "")};
  }

 protected:
  NodeStatus tick() override {
    bool popped = false;
    if (status() == NodeStatus::kIdle) {
      child_running_ = false;
      current_.reset();
      if (static_queue_) current_ = std::make_shared<std::deque<T>>(*static_queue_);
    }
    if (!child_running_) {
      if (!static_queue_) readEntry();
      if (current_ && !current_->empty()) {
        const T value = current_->front();
        current_->pop_front();
        popped = true;
        if (const auto err = setOutput("value", value)) throw RuntimeError(*err);
      }
    }
    if (!popped && !child_running_) return getInput<NodeStatus>("if_empty").value();
    if (status() == NodeStatus::kIdle) setStatus(NodeStatus::kRunning);
    const NodeStatus s = child_->executeTick();
    child_running_ = s == NodeStatus::kRunning;
    if (isCompleted(s)) resetChild();
    return s == NodeStatus::kFailure ? NodeStatus::kFailure : NodeStatus::kRunning;
  }

 private:
  // The queue's entry (made, empty, when missing: then it holds nothing a queue can be read from).
  void readEntry() {
    const auto it = config().input_ports.find("queue");
    if (it == config().input_ports.end()) return;
    const auto key = blackboardKey(it->second, "queue");
    if (!key) return;
    Blackboard::Entry* e = config().blackboard->getEntry(*key);
    if (!e) e = config().blackboard->createEntry(*key, typeInfo<AnyTypeAllowed>());
    const Any& v = e->value;
    if (v.kind() == Any::Kind::kOther && v.other().type() == typeid(SharedQueue<T>)) {
      current_ = std::any_cast<SharedQueue<T>>(v.other());
      return;
    }
    if (current_) return;  // converted when the node started
    if (v.kind() == Any::Kind::kOther && v.other().type() == typeid(std::vector<T>)) {
      const auto& vec = std::any_cast<const std::vector<T>&>(v.other());
      current_ = std::make_shared<std::deque<T>>(vec.begin(), vec.end());
    } else if (v.isString()) {
      current_ = parseQueue<T>(v.string());
    } else {
      throw RuntimeError("LoopNode: port 'queue' must contain either SharedQueue<T>, std::vector<T>, or a string");
    }
  }
  SharedQueue<T> static_queue_, current_;
  bool child_running_ = false;
};

// ---- blackboard entries updated --------------------------------------------------------------

// SkipUnlessUpdated (SKIPPED) and WaitValueUpdate (RUNNING): tick the child only when the entry
// was written since the last look; a running child is ticked on to its end without looking.
template <NodeStatus kIfNotUpdated>
class EntryUpdated final : public DecoratorNode {
 public:
  EntryUpdated(const std::string& name, const NodeConfig& config) : DecoratorNode(name, config), watch_(entryKey(config, name)) {}
  static PortsList providedPorts() { return {inputPort<AnyTypeAllowed>("entry", "Entry to check")}; }
  void halt() override {
    running_ = false;
    DecoratorNode::halt();
  }

 protected:
  NodeStatus tick() override {
    if (!running_ && !watch_.updated(*config().blackboard)) return kIfNotUpdated;
    const NodeStatus s = child_->executeTick();
    running_ = s == NodeStatus::kRunning;
    return s;
  }

 private:
  EntryWatch watch_;
  bool running_ = false;
};

}  // namespace

void registerDecoratorNodes(Factory& f) {
  addBuiltin<LoopNode<int>>(f, "LoopInt", "pops each item of queue (ints) into value and ticks the child");
  addBuiltin<LoopNode<bool>>(f, "LoopBool", "pops each item of queue (bools) into value and ticks the child");
  addBuiltin<LoopNode<double>>(f, "LoopDouble", "pops each item of queue (doubles) into value and ticks the child");
  addBuiltin<LoopNode<std::string>>(f, "LoopString", "pops each item of queue (strings) into value and ticks the child");
  addBuiltin<EntryUpdated<NodeStatus::kSkipped>>(f, "SkipUnlessUpdated", "ticks the child when entry was written since the last look, else SKIPPED");
  addBuiltin<EntryUpdated<NodeStatus::kRunning>>(f, "WaitValueUpdate", "ticks the child when entry was written since the last look, else RUNNING");
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
