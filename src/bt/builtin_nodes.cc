// BT.CPP v4's built-in nodes, written from their documented and observed behaviour (BT.CPP 4.10:
// src/controls/*, src/decorators/*, src/actions/*; traces compared in tests/bt/).
#include "bt/builtin_nodes.h"

#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <set>

#include "bt/factory.h"

namespace mm::bt {
namespace {

// ---- sequences and fallbacks -----------------------------------------------------------------

// Sequence (or, inverted, Fallback): children in order, resuming at the running one. The async
// forms yield (RUNNING with a wake-up) after a child that finished within its first tick.
class SequenceLike : public ControlNode {
 public:
  SequenceLike(const std::string& name, const NodeConfig& config, bool fallback, bool async)
      : ControlNode(name, config), fallback_(fallback), async_(async) {}
  static PortsList providedPorts() { return {}; }
  void halt() override {
    idx_ = 0;
    skipped_ = 0;
    ControlNode::halt();
  }

 protected:
  NodeStatus tick() override {
    const size_t n = childrenCount();
    if (!isActive(status())) skipped_ = 0;
    setStatus(NodeStatus::kRunning);
    const NodeStatus stop = fallback_ ? NodeStatus::kSuccess : NodeStatus::kFailure;
    const NodeStatus next = fallback_ ? NodeStatus::kFailure : NodeStatus::kSuccess;
    while (idx_ < n) {
      TreeNode* c = children_[idx_];
      const NodeStatus prev = c->status();
      const NodeStatus s = c->executeTick();
      if (s == NodeStatus::kRunning) return s;
      if (s == stop) {
        resetChildren();
        idx_ = 0;
        skipped_ = 0;
        return s;
      }
      if (s == next) {
        ++idx_;
        if (async_ && prev == NodeStatus::kIdle && idx_ < n) {
          emitWakeUpSignal();
          return NodeStatus::kRunning;
        }
      } else if (s == NodeStatus::kSkipped) {
        ++idx_;
        ++skipped_;
      } else {
        throw RuntimeError("[" + name() + "]: A children should not return IDLE");
      }
    }
    const bool all_skipped = skipped_ == n;
    if (idx_ == n) {
      resetChildren();
      idx_ = 0;
      skipped_ = 0;
    }
    return all_skipped ? NodeStatus::kSkipped : next;
  }

 private:
  bool fallback_, async_;
  size_t idx_ = 0, skipped_ = 0;
};

class Sequence final : public SequenceLike {
 public:
  Sequence(const std::string& n, const NodeConfig& c) : SequenceLike(n, c, false, false) {}
};
class AsyncSequence final : public SequenceLike {
 public:
  AsyncSequence(const std::string& n, const NodeConfig& c) : SequenceLike(n, c, false, true) {}
};
class Fallback final : public SequenceLike {
 public:
  Fallback(const std::string& n, const NodeConfig& c) : SequenceLike(n, c, true, false) {}
};
class AsyncFallback final : public SequenceLike {
 public:
  AsyncFallback(const std::string& n, const NodeConfig& c) : SequenceLike(n, c, true, true) {}
};

// Keeps its place across failures and halts: the next activation resumes at the failed child.
class SequenceWithMemory final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus tick() override {
    const size_t n = childrenCount();
    if (!isActive(status())) skipped_ = 0;
    setStatus(NodeStatus::kRunning);
    while (idx_ < n) {
      TreeNode* c = children_[idx_];
      const NodeStatus prev = c->status();
      const NodeStatus s = c->executeTick();
      switch (s) {
        case NodeStatus::kRunning: return s;
        case NodeStatus::kFailure:
          for (size_t i = idx_; i < n; ++i) haltChild(i);  // the index stays
          return s;
        case NodeStatus::kSuccess:
          ++idx_;
          if (prev == NodeStatus::kIdle && idx_ < n) {
            emitWakeUpSignal();
            return NodeStatus::kRunning;
          }
          break;
        case NodeStatus::kSkipped:
          ++idx_;
          ++skipped_;
          break;
        case NodeStatus::kIdle: throw RuntimeError("[" + name() + "]: A children should not return IDLE");
      }
    }
    const bool all_skipped = skipped_ == n;
    if (idx_ == n) {
      resetChildren();
      idx_ = 0;
      skipped_ = 0;
    }
    return all_skipped ? NodeStatus::kSkipped : NodeStatus::kSuccess;
  }

 private:
  size_t idx_ = 0, skipped_ = 0;
};

// Every child from the first on each tick; a running child halts the others.
class ReactiveLike : public ControlNode {
 public:
  ReactiveLike(const std::string& name, const NodeConfig& config, bool fallback)
      : ControlNode(name, config), fallback_(fallback) {}
  static PortsList providedPorts() { return {}; }
  void halt() override {
    running_ = -1;
    ControlNode::halt();
  }

 protected:
  NodeStatus tick() override {
    bool all_skipped = true;
    if (status() == NodeStatus::kIdle) running_ = -1;
    setStatus(NodeStatus::kRunning);
    const NodeStatus stop = fallback_ ? NodeStatus::kSuccess : NodeStatus::kFailure;
    for (size_t i = 0; i < childrenCount(); ++i) {
      const NodeStatus s = children_[i]->executeTick();
      all_skipped &= s == NodeStatus::kSkipped;
      if (s == NodeStatus::kRunning) {
        for (size_t j = 0; j < childrenCount(); ++j)
          if (j != i) haltChild(j);
        if (running_ == -1) running_ = static_cast<int>(i);
        return s;
      }
      if (s == stop) {
        resetChildren();
        return s;
      }
      if (s == NodeStatus::kSkipped) haltChild(i);
      if (s == NodeStatus::kIdle) throw RuntimeError("[" + name() + "]: A children should not return IDLE");
    }
    resetChildren();
    return all_skipped ? NodeStatus::kSkipped : (fallback_ ? NodeStatus::kFailure : NodeStatus::kSuccess);
  }

 private:
  bool fallback_;
  int running_ = -1;
};
class ReactiveSequence final : public ReactiveLike {
 public:
  ReactiveSequence(const std::string& n, const NodeConfig& c) : ReactiveLike(n, c, false) {}
};
class ReactiveFallback final : public ReactiveLike {
 public:
  ReactiveFallback(const std::string& n, const NodeConfig& c) : ReactiveLike(n, c, true) {}
};

// ---- parallel --------------------------------------------------------------------------------

size_t threshold(int t, size_t n) {
  return t < 0 ? static_cast<size_t>(std::max(static_cast<int>(n) + t + 1, 0)) : static_cast<size_t>(t);
}

class Parallel final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList providedPorts() {
    return {inputPort<int>("success_count", "-1", "number of children that need to succeed to trigger a SUCCESS"),
            inputPort<int>("failure_count", "1", "number of children that need to fail to trigger a FAILURE")};
  }
  void halt() override {
    clear();
    ControlNode::halt();
  }

 protected:
  NodeStatus tick() override {
    const int success_port = getInput<int>("success_count").value();
    const int failure_port = getInput<int>("failure_count").value();
    const size_t n = childrenCount();
    const size_t need_success = threshold(success_port, n), need_failure = threshold(failure_port, n);
    if (n < need_success) throw RuntimeError("Number of children is less than threshold. Can never succeed.");
    if (n < need_failure) throw RuntimeError("Number of children is less than threshold. Can never fail.");
    setStatus(NodeStatus::kRunning);
    size_t skipped = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!completed_.count(i)) {
        const NodeStatus s = children_[i]->executeTick();
        if (s == NodeStatus::kSkipped) ++skipped;
        else if (s == NodeStatus::kSuccess) completed_.insert(i), ++successes_;
        else if (s == NodeStatus::kFailure) completed_.insert(i), ++failures_;
        else if (s == NodeStatus::kIdle) throw RuntimeError("[" + name() + "]: A children should not return IDLE");
      }
      if (successes_ >= need_success || (success_port < 0 && successes_ + skipped >= need_success)) {
        clear();
        resetChildren();
        return NodeStatus::kSuccess;
      }
      if (n - failures_ < need_success || failures_ == need_failure) {
        clear();
        resetChildren();
        return NodeStatus::kFailure;
      }
    }
    return skipped == n ? NodeStatus::kSkipped : NodeStatus::kRunning;
  }

 private:
  void clear() {
    completed_.clear();
    successes_ = failures_ = 0;
  }
  std::set<size_t> completed_;
  size_t successes_ = 0, failures_ = 0;
};

class ParallelAll final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList providedPorts() {
    return {inputPort<int>("max_failures", "1",
                           "If the number of children returning FAILURE exceeds this value, ParallelAll returns FAILURE")};
  }
  void halt() override {
    completed_.clear();
    failures_ = 0;
    ControlNode::halt();
  }

 protected:
  NodeStatus tick() override {
    const size_t n = childrenCount();
    const size_t need = threshold(getInput<int>("max_failures").value(), n);
    if (n < need) throw RuntimeError("Number of children is less than threshold. Can never fail.");
    setStatus(NodeStatus::kRunning);
    size_t skipped = 0;
    for (size_t i = 0; i < n; ++i) {
      if (completed_.count(i)) continue;
      const NodeStatus s = children_[i]->executeTick();
      if (s == NodeStatus::kSuccess) completed_.insert(i);
      else if (s == NodeStatus::kFailure) completed_.insert(i), ++failures_;
      else if (s == NodeStatus::kSkipped) ++skipped;
      else if (s == NodeStatus::kIdle) throw RuntimeError("[" + name() + "]: A children should not return IDLE");
    }
    if (skipped == n) return NodeStatus::kSkipped;
    if (skipped + completed_.size() >= n) {
      haltChildren();
      completed_.clear();
      const NodeStatus s = failures_ >= need ? NodeStatus::kFailure : NodeStatus::kSuccess;
      failures_ = 0;
      return s;
    }
    return NodeStatus::kRunning;
  }

 private:
  std::set<size_t> completed_;
  size_t failures_ = 0;
};

// ---- conditional controls --------------------------------------------------------------------

// The condition once, then the chosen branch until it finishes.
class IfThenElse final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList providedPorts() { return {}; }
  void halt() override {
    idx_ = 0;
    ControlNode::halt();
  }

 protected:
  NodeStatus tick() override {
    const size_t n = childrenCount();
    setStatus(NodeStatus::kRunning);
    if (idx_ == 0) {
      const NodeStatus c = children_[0]->executeTick();
      if (c == NodeStatus::kRunning) return c;
      if (c == NodeStatus::kSuccess) idx_ = 1;
      else if (c == NodeStatus::kFailure) {
        if (n == 3) idx_ = 2;
        else return c;
      }
    }
    if (idx_ > 0) {
      const NodeStatus s = children_[idx_]->executeTick();
      if (s == NodeStatus::kRunning) return s;
      resetChildren();
      idx_ = 0;
      return s;
    }
    throw RuntimeError("Something unexpected happened in IfThenElseNode");
  }

 private:
  size_t idx_ = 0;
};

// Reactive if-then-else: the condition on every tick, switching (and halting) branches.
class WhileDoElse final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList providedPorts() { return {}; }

 protected:
  NodeStatus tick() override {
    const size_t n = childrenCount();
    setStatus(NodeStatus::kRunning);
    const NodeStatus c = children_[0]->executeTick();
    if (c == NodeStatus::kRunning) return c;
    NodeStatus s = NodeStatus::kIdle;
    if (c == NodeStatus::kSuccess) {
      if (n == 3) haltChild(2);
      s = children_[1]->executeTick();
    } else if (c == NodeStatus::kFailure) {
      if (n == 3) {
        haltChild(1);
        s = children_[2]->executeTick();
      } else {
        s = NodeStatus::kFailure;
      }
    }
    if (s == NodeStatus::kRunning) return s;
    resetChildren();
    return s;  // IDLE when the condition was skipped: executeTick refuses it, as in BT.CPP
  }
};

// Switch<N>: the child whose case_k equals `variable` (as strings, integers or reals), else the last.
bool sameCase(const std::string& a, const std::string& b, const ScriptEnums* enums) {
  if (a == b) return true;
  auto toInt = [enums](const std::string& s, long& v) {
    if (enums)
      if (auto it = enums->find(s); it != enums->end()) return v = it->second, true;
    const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    return ec == std::errc() && p == s.data() + s.size();
  };
  long x = 0, y = 0;
  if (toInt(a, x) && toInt(b, y) && x == y) return true;
  auto toReal = [enums](const std::string& s, double& v) {
    if (enums)
      if (auto it = enums->find(s); it != enums->end()) return v = it->second, true;
    const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    return ec == std::errc() && p == s.data() + s.size();
  };
  double u = 0, w = 0;
  return toReal(a, u) && toReal(b, w) && std::abs(u - w) <= static_cast<double>(std::numeric_limits<float>::epsilon());
}

template <int N>
class Switch final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList providedPorts() {
    PortsList p;
    p.insert(optionalInputPort<std::string>("variable", "the value compared with each case"));
    for (int k = 1; k <= N; ++k) p.insert(optionalInputPort<std::string>("case_" + std::to_string(k), ""));
    return p;
  }
  void halt() override {
    running_ = -1;
    ControlNode::halt();
  }

 protected:
  NodeStatus tick() override {
    int match = N;
    if (const auto variable = getInput<std::string>("variable")) {
      for (int k = 0; k < N; ++k) {
        const auto value = getInput<std::string>("case_" + std::to_string(k + 1));
        if (value && sameCase(*variable, *value, config().enums)) {
          match = k;
          break;
        }
      }
    }
    if (running_ != -1 && running_ != match) haltChild(running_);
    const NodeStatus s = children_[match]->executeTick();
    if (s == NodeStatus::kSkipped) {
      running_ = -1;
      return s;
    }
    if (s == NodeStatus::kRunning) {
      running_ = match;
      return s;
    }
    resetChildren();
    running_ = -1;
    return s;
  }

 private:
  int running_ = -1;
};

// ---- decorators ------------------------------------------------------------------------------

// One pending timer on the tree's clock (Timeout, Delay, Sleep): started once, it clears itself
// before its callback runs, and is cancelled when the node cancels it or is destroyed.
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

template <class T>
void add(Factory& f, const std::string& id, const std::string& description, int min_children = -2, int max_children = -2) {
  f.registerNodeType<T>(id, description);
  if (min_children != -2) {
    NodeManifest m = f.manifests().at(id);
    m.min_children = min_children;
    m.max_children = max_children;
    f.registerNode(std::move(m));
  }
}

}  // namespace

void registerBuiltinNodes(Factory& f) {
  add<Sequence>(f, "Sequence", "children in order until one fails");
  add<AsyncSequence>(f, "AsyncSequence", "Sequence that yields between synchronous children");
  add<SequenceWithMemory>(f, "SequenceWithMemory", "Sequence that resumes at the failed child");
  add<ReactiveSequence>(f, "ReactiveSequence", "every child from the first on each tick");
  add<Fallback>(f, "Fallback", "children in order until one succeeds");
  add<AsyncFallback>(f, "AsyncFallback", "Fallback that yields between synchronous children");
  add<ReactiveFallback>(f, "ReactiveFallback", "every child from the first on each tick, until one succeeds");
  add<Parallel>(f, "Parallel", "all children at once, thresholds of successes and failures");
  add<ParallelAll>(f, "ParallelAll", "all children to completion");
  add<IfThenElse>(f, "IfThenElse", "condition once, then a branch", 2, 3);
  add<WhileDoElse>(f, "WhileDoElse", "condition every tick, the matching branch", 2, 3);
  add<Switch<2>>(f, "Switch2", "the child whose case matches the variable", 3, 3);
  add<Switch<3>>(f, "Switch3", "the child whose case matches the variable", 4, 4);
  add<Switch<4>>(f, "Switch4", "the child whose case matches the variable", 5, 5);
  add<Switch<5>>(f, "Switch5", "the child whose case matches the variable", 6, 6);
  add<Switch<6>>(f, "Switch6", "the child whose case matches the variable", 7, 7);
  add<RetryUntilSuccessful>(f, "RetryUntilSuccessful", "ticks a failing child again, up to num_attempts times");
  add<Repeat>(f, "Repeat", "ticks a succeeding child again, num_cycles times");
  add<Inverter>(f, "Inverter", "SUCCESS <-> FAILURE");
  add<Force<true>>(f, "ForceSuccess", "SUCCESS whenever the child completes");
  add<Force<false>>(f, "ForceFailure", "FAILURE whenever the child completes");
  add<KeepRunningUntilFailure>(f, "KeepRunningUntilFailure", "RUNNING until the child fails");
  add<Timeout>(f, "Timeout", "halts the child after msec and fails");
  add<Delay>(f, "Delay", "waits delay_msec, then ticks the child");
  add<RunOnce>(f, "RunOnce", "ticks the child once in the tree's life");
  add<Precondition>(f, "Precondition", "ticks the child while the script holds, else returns else");
  add<AlwaysSuccess>(f, "AlwaysSuccess", "SUCCESS");
  add<AlwaysFailure>(f, "AlwaysFailure", "FAILURE");
  add<SetBlackboard>(f, "SetBlackboard", "writes value into output_key");
  add<UnsetBlackboard>(f, "UnsetBlackboard", "removes key");
  add<Sleep>(f, "Sleep", "RUNNING for msec");
  add<ScriptAction>(f, "Script", "runs code");
  add<ScriptCondition>(f, "ScriptCondition", "runs code; SUCCESS if true");
}

}  // namespace mm::bt
