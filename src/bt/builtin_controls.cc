// BT.CPP v4's built-in control nodes (sequences, fallbacks, parallels, conditional controls),
// written from their documented and observed behaviour (BT.CPP 4.10: src/controls/*; traces
// compared in tests/bt/).
#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <set>

#include "bt/builtin_register.h"
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

// ---- try and catch -----------------------------------------------------------------------------

// TryCatch: children 1..N-1 as a Sequence (the try block); when one fails, the last child (the
// catch) runs to its end and the node fails whatever it returns. A try block that succeeds
// (skipped children passed over) succeeds, SKIPPED when every try child was skipped. With
// catch_on_halt, a halt during the try block ticks the catch once before halting (a catch still
// RUNNING then is halted too). Fewer than two children is refused when the tree loads.
class TryCatch final : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList providedPorts() {
    return {inputPort<bool>("catch_on_halt", "false", "If true, execute the catch child when the node is halted during the try-block")};
  }
  void halt() override {
    const auto on_halt = getInput<bool>("catch_on_halt");
    if (on_halt && *on_halt && !catching_ && isActive(status()) && childrenCount() >= 2) {
      for (size_t i = 0; i + 1 < childrenCount(); ++i) haltChild(i);
      if (children_.back()->executeTick() == NodeStatus::kRunning) haltChild(childrenCount() - 1);
    }
    idx_ = 0;
    skipped_ = 0;
    catching_ = false;
    ControlNode::halt();
  }

 protected:
  NodeStatus tick() override {
    const size_t n = childrenCount();
    if (n < 2) throw RuntimeError("[" + name() + "]: TryCatch requires at least 2 children");  // refused at load already
    if (!isActive(status())) {
      skipped_ = 0;
      catching_ = false;
    }
    setStatus(NodeStatus::kRunning);
    if (catching_) {
      if (children_.back()->executeTick() == NodeStatus::kRunning) return NodeStatus::kRunning;
      resetChildren();
      idx_ = 0;
      catching_ = false;
      return NodeStatus::kFailure;
    }
    const size_t tries = n - 1;
    while (idx_ < tries) {
      const NodeStatus s = children_[idx_]->executeTick();
      if (s == NodeStatus::kRunning) return s;
      if (s == NodeStatus::kFailure) {
        resetChildren();
        idx_ = 0;
        catching_ = true;
        return tick();  // the catch, in the same tick
      }
      if (s == NodeStatus::kIdle) throw RuntimeError("[" + name() + "]: A child should not return IDLE");
      if (s == NodeStatus::kSkipped) ++skipped_;
      ++idx_;
    }
    const bool all_skipped = skipped_ == tries;
    resetChildren();
    idx_ = 0;
    skipped_ = 0;
    return all_skipped ? NodeStatus::kSkipped : NodeStatus::kSuccess;
  }

 private:
  size_t idx_ = 0, skipped_ = 0;
  bool catching_ = false;
};

}  // namespace

void registerControlNodes(Factory& f) {
  addBuiltin<Sequence>(f, "Sequence", "children in order until one fails");
  addBuiltin<AsyncSequence>(f, "AsyncSequence", "Sequence that yields between synchronous children");
  addBuiltin<SequenceWithMemory>(f, "SequenceWithMemory", "Sequence that resumes at the failed child");
  addBuiltin<ReactiveSequence>(f, "ReactiveSequence", "every child from the first on each tick");
  addBuiltin<Fallback>(f, "Fallback", "children in order until one succeeds");
  addBuiltin<AsyncFallback>(f, "AsyncFallback", "Fallback that yields between synchronous children");
  addBuiltin<ReactiveFallback>(f, "ReactiveFallback", "every child from the first on each tick, until one succeeds");
  addBuiltin<Parallel>(f, "Parallel", "all children at once, thresholds of successes and failures");
  addBuiltin<ParallelAll>(f, "ParallelAll", "all children to completion");
  addBuiltin<IfThenElse>(f, "IfThenElse", "condition once, then a branch", 2, 3);
  addBuiltin<TryCatch>(f, "TryCatch", "children but the last as a Sequence; when one fails, the last (the catch) runs and the node fails", 2, -1);
  addBuiltin<WhileDoElse>(f, "WhileDoElse", "condition every tick, the matching branch", 2, 3);
  addBuiltin<Switch<2>>(f, "Switch2", "the child whose case matches the variable", 3, 3);
  addBuiltin<Switch<3>>(f, "Switch3", "the child whose case matches the variable", 4, 4);
  addBuiltin<Switch<4>>(f, "Switch4", "the child whose case matches the variable", 5, 5);
  addBuiltin<Switch<5>>(f, "Switch5", "the child whose case matches the variable", 6, 6);
  addBuiltin<Switch<6>>(f, "Switch6", "the child whose case matches the variable", 7, 7);
}

}  // namespace mm::bt
