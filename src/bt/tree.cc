#include "bt/tree.h"

#include <algorithm>
#include <chrono>

namespace mm::bt {

Tree::Tree() = default;
Tree::~Tree() = default;

NodeStatus Tree::tickOnce(int max_reticks, const std::function<void()>& on_retick) {
  NodeStatus s = root_->executeTick();
  for (int k = 0; k < max_reticks && s == NodeStatus::kRunning && takeWakeUpSignal(); ++k) {
    if (on_retick) on_retick();
    s = root_->executeTick();
  }
  if (isCompleted(s)) root_->resetStatus();
  return s;
}

void Tree::haltTree() {
  if (!root_) return;
  root_->haltNode();
  for (TreeNode* n : nodes()) n->haltNode();  // every node's _onHalted, as BT.CPP's visitor
  root_->resetStatus();
}

std::vector<TreeNode*> Tree::nodes() const {
  std::vector<TreeNode*> out;
  for (const auto& n : nodes_) out.push_back(n.get());
  std::sort(out.begin(), out.end(), [](const TreeNode* a, const TreeNode* b) { return a->uid() < b->uid(); });
  return out;
}

int Tree::addObserver(StatusObserver observer) {
  observers_.push_back({next_observer_, std::move(observer)});
  return next_observer_++;
}

void Tree::removeObserver(int id) {
  observers_.erase(std::remove_if(observers_.begin(), observers_.end(), [id](const auto& o) { return o.first == id; }),
                   observers_.end());
}

void Tree::notify(const TreeNode& node, NodeStatus prev, NodeStatus now) const {
  for (const auto& o : observers_) o.second(node, prev, now);
}

double Tree::now() const {
  if (clock_) return clock_();
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

int Tree::addTimer(double delay, std::function<void()> fn) {
  const int id = next_timer_++;
  timers_.push_back({id, now() + delay, std::move(fn)});
  return id;
}

void Tree::cancelTimer(int id) {
  timers_.erase(std::remove_if(timers_.begin(), timers_.end(), [id](const Timer& t) { return t.id == id; }), timers_.end());
}

std::optional<double> Tree::nextTimerDeadline() const {
  std::optional<double> d;
  for (const Timer& t : timers_)
    if (!d || t.deadline < *d) d = t.deadline;
  return d;
}

bool Tree::fireDueTimers() {
  bool any = false;
  const double t = now();
  for (;;) {
    // In deadline order, then creation order; a callback may add or cancel timers.
    auto due = timers_.end();
    for (auto it = timers_.begin(); it != timers_.end(); ++it)
      if (it->deadline <= t + 1e-12 && (due == timers_.end() || it->deadline < due->deadline)) due = it;
    if (due == timers_.end()) return any;
    std::function<void()> fn = std::move(due->fn);
    timers_.erase(due);
    fn();
    any = true;
  }
}

bool Tree::takeWakeUpSignal() {
  const bool w = wake_up_;
  wake_up_ = false;
  return w;
}

TreeNode* Tree::adopt(std::unique_ptr<TreeNode> node) {
  nodes_.push_back(std::move(node));
  return nodes_.back().get();
}

Blackboard* Tree::newBlackboard(Blackboard* parent) {
  blackboards_.push_back(std::make_unique<Blackboard>(parent));
  return blackboards_.back().get();
}

}  // namespace mm::bt
