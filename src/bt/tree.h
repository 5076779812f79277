// A tree built from XML: its nodes (UIDs from 1 in depth-first order, SubTrees expanded where
// they stand), one blackboard per SubTree instance, a clock, timers and the wake-up signal.
// Time is whatever the clock says: the harness gives it the trial's simulated time, so Sleep,
// Delay and Timeout count simulated seconds and timers fire between ticks, deterministically.
#pragma once
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bt/blackboard.h"
#include "bt/tree_node.h"

namespace mm::bt {

class Tree {
 public:
  /// One SubTree instance (the main tree is the first, with an empty instance name).
  struct Subtree {
    std::string instance_name;  ///< its path ("" for the main tree)
    std::string tree_id;
    Blackboard* blackboard = nullptr;
    std::vector<TreeNode*> nodes;  ///< in creation order (the SubTree node itself belongs to its parent)
  };
  using StatusObserver = std::function<void(const TreeNode&, NodeStatus prev, NodeStatus now)>;

  Tree();
  ~Tree();
  Tree(const Tree&) = delete;  // nodes point at their tree
  Tree& operator=(const Tree&) = delete;

  /// Ticks the root; while a node asked for a wake-up during the tick, ticks again at once (at
  /// most `max_reticks` times); a finished root goes back to IDLE. BT.CPP's tickOnce().
  NodeStatus tickOnce(int max_reticks = 1000, const std::function<void()>& on_retick = {});
  /// Halts every node (the root first, then each node's _onHalted as BT.CPP), root to IDLE.
  void haltTree();

  TreeNode* root() const { return root_; }
  Blackboard& rootBlackboard() { return *blackboards_.front(); }
  const std::vector<Subtree>& subtrees() const { return subtrees_; }
  /// Every node in UID order.
  std::vector<TreeNode*> nodes() const;
  const std::string& mainTreeId() const { return subtrees_.front().tree_id; }

  /// Calls `observer` on every status change; returns its id for removeObserver().
  int addObserver(StatusObserver observer);
  void removeObserver(int id);
  void notify(const TreeNode& node, NodeStatus prev, NodeStatus now) const;

  // Time: seconds on the tree's clock (wall time unless set).
  void setClock(std::function<double()> clock) { clock_ = std::move(clock); }
  double now() const;
  /// Calls `fn` once the clock passes now + `delay` [s] (between ticks, see fireDueTimers()).
  int addTimer(double delay, std::function<void()> fn);
  void cancelTimer(int id);
  std::optional<double> nextTimerDeadline() const;
  /// Runs the callbacks of the timers due now; true if any ran.
  bool fireDueTimers();

  void emitWakeUpSignal() { wake_up_ = true; }
  /// Whether a wake-up was asked for since the last call (and clears it).
  bool takeWakeUpSignal();

  // Building (the factory).
  TreeNode* adopt(std::unique_ptr<TreeNode> node);
  Blackboard* newBlackboard(Blackboard* parent);
  void addSubtree(Subtree s) { subtrees_.push_back(std::move(s)); }
  Subtree& subtree(size_t i) { return subtrees_[i]; }
  void setRoot(TreeNode* root) { root_ = root; }
  uint16_t nextUid() { return ++uid_counter_; }

 private:
  // Declared before the nodes so that they are destroyed after them: a node's destructor may
  // cancel its timer.
  std::vector<std::pair<int, StatusObserver>> observers_;
  int next_observer_ = 1;
  std::function<double()> clock_;
  struct Timer {
    int id;
    double deadline;
    std::function<void()> fn;
  };
  std::vector<Timer> timers_;
  int next_timer_ = 1;
  std::vector<std::unique_ptr<Blackboard>> blackboards_;
  std::vector<std::unique_ptr<TreeNode>> nodes_;
  std::vector<Subtree> subtrees_;
  TreeNode* root_ = nullptr;
  bool wake_up_ = false;
  uint16_t uid_counter_ = 0;
};

}  // namespace mm::bt
