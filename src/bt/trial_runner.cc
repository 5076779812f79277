#include "bt/trial_runner.h"

#include <chrono>
#include <cmath>
#include <sstream>

namespace mm::bt {

void TreeRunOptions::declare(ConfigArchive& a) {
  a.value("tick_period", tick_period, {0.001, 10.0}, "s", "simulated time between ticks (an action that finishes wakes the tree at once)");
  a.value("time_budget", time_budget, {1.0, 1e6}, "s", "simulated time a trial may take; a tree still running then ends as TIMEOUT");
}

TreeRunResult runTree(Tree& tree, TrialContext& ctx, const TreeRunOptions& o) {
  TreeRunResult r;
  tree.setClock([&ctx] { return ctx.simTime(); });
  // The last leaf or decorator that failed, to explain a FAILURE no action recorded.
  std::string last_failed;
  const int observer = tree.addObserver([&](const TreeNode& n, NodeStatus, NodeStatus now) {
    if (now == NodeStatus::kFailure && n.kind() != NodeKind::kControl && n.kind() != NodeKind::kSubTree)
      last_failed = n.fullPath() + " [" + n.registrationId() + "]";
  });
  constexpr double kEps = 1e-9;
  // A tree that keeps waking itself without time passing gets this many ticks at one instant,
  // then waits for the next regular tick.
  constexpr int kMaxTicksAtOneInstant = 100;
  int ticks_now = 0;
  double last_tick_time = -1;
  auto tick = [&] {
    const double t = ctx.simTime();
    ticks_now = std::abs(t - last_tick_time) < kEps ? ticks_now + 1 : 1;
    last_tick_time = t;
    ++r.ticks;
    const double leaf0 = leafTickSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    r.status = tree.tickOnce(kMaxTicksAtOneInstant, [&] { ++r.ticks; });
    r.tick_wall_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.leaf_wall_seconds += leafTickSeconds() - leaf0;
  };
  try {
    tick();
    while (r.status == NodeStatus::kRunning && !ctx.out.sim_unstable) {
      const double next_tick = ctx.simTime() + o.tick_period;
      bool wake = false;
      const bool wakes_allowed = ticks_now < kMaxTicksAtOneInstant;
      while (!wake) {
        if (tree.fireDueTimers() && wakes_allowed) {  // Sleep, Delay, Timeout: due now
          wake = true;
          break;
        }
        const double now = ctx.simTime();
        if (now >= next_tick - kEps) break;
        if (now >= o.time_budget - kEps) {
          r.timeout = true;
          break;
        }
        const Executor::Step s = ctx.executor.step();
        // A motion ended: the action that waits on it decides now.
        wake = s != Executor::Step::kStepped && wakes_allowed;
      }
      if (r.timeout) break;
      tick();
    }
  } catch (const std::exception& e) {
    r.error = e.what();
  }
  r.unstable = ctx.out.sim_unstable;
  const bool running = tree.root()->status() == NodeStatus::kRunning || r.timeout || r.unstable || !r.error.empty();
  if (running) {
    try {
      tree.haltTree();  // running actions stop; a moving arm brakes
    } catch (const std::exception& e) {
      if (r.error.empty()) r.error = std::string("while halting the tree: ") + e.what();
    }
  }
  tree.removeObserver(observer);
  // The arm comes to rest (a halted motion brakes to its end) before the trial's failure is told.
  while (ctx.executor.busy()) ctx.executor.step();
  std::ostringstream budget;
  budget << o.time_budget;
  if (r.timeout) {
    ctx.fail({"tree", FailureKind::kTimeout, "TIMEOUT: the tree was still running after " + budget.str() + " s of simulated time"});
  } else if (!r.error.empty()) {
    ctx.fail({"tree", FailureKind::kTree, "error in the tree: " + r.error});
  } else if (r.status == NodeStatus::kFailure && !r.unstable) {
    if (!ctx.unhandledFailure())
      ctx.fail({"tree", FailureKind::kTree,
                "the tree returned FAILURE" + (last_failed.empty() ? std::string() : " (last failing node: " + last_failed + ")")});
  }
  return r;
}

}  // namespace mm::bt
