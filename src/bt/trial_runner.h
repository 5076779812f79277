// Runs a behavior tree over one trial on simulated time: the tree is ticked every tick_period
// (the source's 10 Hz) with the 500 Hz controller stepping the hardware in between; an action
// whose motion ends, or a timer (Sleep, Delay, Timeout) that fires, wakes the tree at once, as
// BT.CPP's wake-up signal does, so no stage waits for the next tick. A tree still running after
// the trial's simulated-time budget is halted and the trial ends as TIMEOUT.
#pragma once
#include <string>

#include "bt/tree.h"
#include "core/config.h"
#include "task/trial_context.h"

namespace mm::bt {

struct TreeRunOptions {
  /// Keys tick_period, time_budget (section "bt").
  void declare(ConfigArchive& a);
  double tick_period = 0.1;   ///< [s] simulated
  double time_budget = 120;   ///< [s] simulated; then TIMEOUT
};

struct TreeRunResult {
  NodeStatus status = NodeStatus::kIdle;  ///< SUCCESS or FAILURE (RUNNING when it timed out)
  bool timeout = false;
  bool unstable = false;                   ///< stopped where the simulator flagged a bad state (its world is reset)
  long ticks = 0;                          ///< root ticks, re-ticks after a wake-up included
  double tick_wall_seconds = 0;            ///< wall time inside the ticks (the actions' planning included)
  double leaf_wall_seconds = 0;            ///< of it, inside the leaf nodes (actions and conditions)
  std::string error;                       ///< a runtime error in the tree (a script, a port), if any
};

/// Runs `tree` to its end on `ctx` (the tree's clock becomes the trial's simulated time), or until
/// an action records a SIM_UNSTABLE failure (MuJoCo has reset its state: nothing after it would be
/// a trial, and that failure stays the trial's). Records a TIMEOUT, a runtime error or a FAILURE
/// no action explained as the trial's failure.
TreeRunResult runTree(Tree& tree, TrialContext& ctx, const TreeRunOptions& options);

}  // namespace mm::bt
