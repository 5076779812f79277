// Joint-space motion planning with OMPL, seeded from our RNG streams so the same problem and seed
// give the same path whatever thread runs it. OMPL headers stay in planner.cc.
#pragma once
#include <string>
#include <vector>

#include "core/config.h"
#include "core/failure.h"
#include "planning/collision.h"
#include "robot/robot_model.h"

namespace mm {

/// The OMPL planners available by name.
std::vector<std::string> plannerNames();
/// Seeds OMPL's global generator (once per process, before any planning): the planners other
/// than RRTConnect draw on it, deterministic in a single thread (plan-bench).
void seedOmplGlobally(uint32_t seed);

struct PlannerOptions {
  /// Keys planner, time_limit, simplify, resolution (section "planning").
  void declare(ConfigArchive& a);
  std::string planner = "RRTConnect";  ///< one of plannerNames()
  double time_limit = 5.0;        ///< [s] wall-clock safety cap; reaching it is recorded
  double resolution = 0.02;       ///< [rad] edge validation step (joint-space distance)
  bool simplify = true;           ///< shortcut and vertex reduction after planning
  int simplify_steps = 100;       ///< shortcutting attempts
  /// Test only: each state the planner validates is checked this many times (a deliberately slowed
  /// planner, for the gate's test: same paths, more collision checks and wall time).
  int test_slowdown = 1;
  /// Test only: each planning call takes this many times its wall time (the rest spent waiting,
  /// busy): a planner N times slower with the same paths and counters, for the timing gate's test.
  double test_time_factor = 1.0;
};

struct PlanResult {
  bool ok = false;
  std::vector<VecX> path;   ///< waypoints including start and goal
  std::string reason;       ///< why it failed
  FailureKind kind = FailureKind::kNone;  ///< kCollision (start or goal invalid) or kPlanning
  double plan_seconds = 0;      ///< wall time of the planner
  double simplify_seconds = 0;  ///< wall time of the simplifier
  long collision_checks = 0;
  bool hit_time_limit = false;
  double length = 0;        ///< joint-space path length [rad] (after simplification)
  double raw_length = 0;    ///< before simplification
  int raw_waypoints = 0;
};

/// Plans from `start` to `goal` (both dim dof). A start or goal in collision fails at once with
/// the colliding pair named; the goal is never moved.
PlanResult planJointPath(const RobotModel& robot, CollisionChecker& checker, const VecX& start, const VecX& goal,
                         uint64_t seed, const PlannerOptions& options);

/// OMPL's version, e.g. "1.5.2".
std::string omplVersion();

/// True when the straight joint-space segment a-b is valid at the given resolution [rad].
bool segmentValid(CollisionChecker& checker, const VecX& a, const VecX& b, double resolution);

}  // namespace mm
