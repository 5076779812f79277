// Pick and place as a chain of stages, the shape of the source's MoveIt Task Constructor task:
// CurrentState -> OpenGripper -> Connect(pre-grasp) -> GraspPose+IK -> Approach -> Close -> Attach
// -> Lift -> Connect(pre-place) -> Place -> Open -> Detach -> Retreat, then home. Each stage is
// timed (compute wall time apart from simulated time) and can fail with its name and a reason.
#pragma once
#include <string>
#include <vector>

#include "core/geometry.h"
#include "grasp/grasp.h"
#include "kinematics/ik.h"
#include "perception/perception.h"
#include "planning/cartesian.h"
#include "planning/planner.h"
#include "planning/trajectory.h"
#include "robot/robot_model.h"

namespace mm {

class Hardware;

struct TaskOptions {
  PlannerOptions planner;
  double padding = 0.01;                 ///< [m] robot inflation against the world when planning
  std::string checker = "spheres+fcl";   ///< collision checker: "spheres", "spheres+fcl" or "fcl"
  std::string time_parameterization = "jerk_limited";  ///< joint paths: a name of timeParameterizationNames()
  std::string optimizer = "none";        ///< "none" or "chomp" after the planner
  LimitScaling scaling{0.5, 0.5};        ///< fraction of velocity / acceleration limits
  CartesianOptions cartesian;
  std::string ik_solver = "analytic";   ///< see ikSolverNames()
  IkRequest ik;                          ///< tolerances and budgets of the grasp/place IK
  GraspOptions grasp;
  int max_grasp_candidates = 8;
  double approach_distance = 0.10;       ///< [m] pre-grasp above the grasp
  double lift_height = 0.15;             ///< [m]
  double place_clearance = 0.005;        ///< [m] object bottom above the surface at release
  double retreat_distance = 0.10;        ///< [m]
  double grasp_force = 40.0;             ///< [N] per finger
  double finger_margin = 0.012;          ///< [m] per finger beyond the object's half width when open
  bool weld = false;                     ///< weld-on-grasp (attach plugin) instead of friction
  double drop_distance = 0.03;           ///< [m] object this far from its in-hand pose = dropped
  double settle_time = 0.5;              ///< [s] simulated rest before the evaluation
  // Success criteria.
  double tolerance_position = 0.02;      ///< [m] horizontal distance to the place target
  double tolerance_orientation = 0.1745; ///< [rad] (10 degrees)
};

struct StageRecord {
  std::string name;
  bool ok = true;
  double compute_seconds = 0;  ///< wall time of planning/IK/perception in this stage
  double sim_seconds = 0;      ///< simulated execution time in this stage
};

/// One trial's outcome. Times are [s]; errors [m] and [rad].
struct TrialOutcome {
  bool success = false;
  std::string failure_stage, failure_reason;
  bool sim_unstable = false;
  bool dropped = false;
  int target_object = -1;
  int objects_in_bin = 0;
  int grasp_candidates_tried = 0;
  // The source's time breakdown (compute stages in wall time, execution in simulated time).
  double perception_time = 0, plan_pick_time = 0, execute_pick_time = 0, plan_place_time = 0,
         execute_place_time = 0, return_home_time = 0, total_time = 0;
  double sim_time = 0;      ///< simulated seconds of the whole trial (deterministic)
  double compute_time = 0;  ///< wall seconds of the blocking computation
  double place_position_error = 0, place_orientation_error = 0;
  int collision_count = 0;
  std::vector<std::string> collision_log;
  double max_tracking_error = 0;
  long collision_checks = 0;
  double grasp_opening = 0;  ///< [m] per finger after closing
  // Recovery (filled by the behavior-tree layer when it runs the trial).
  bool recovery_needed = false, recovery_success = false;
  int recovery_attempts = 0;
  std::vector<StageRecord> stages;
};

struct PlaceTarget {
  Pose T_world_object;  ///< where the object should rest
};

/// Runs one pick-and-place on `hw`. `static_obstacles` are the table, bins and tray as the
/// planner knows them. All randomness comes from streams of (campaign_seed, trial).
TrialOutcome runPickAndPlace(Hardware& hw, const RobotModel& robot, const std::vector<Obstacle>& static_obstacles,
                             const PlaceTarget& target, const TaskOptions& task, const PerceptionOptions& perception,
                             uint64_t campaign_seed, uint64_t trial);

}  // namespace mm
