// Expected failures as values: what went wrong inside a trial (kind), where (stage) and why
// (reason). Never matched on their text: code branches on the kind.
#pragma once
#include <string>

namespace mm {

enum class FailureKind {
  kNone = 0,
  kPerception,            ///< nothing (usable) detected
  kNoGrasp,               ///< no grasp candidate for the object
  kIk,                    ///< no IK solution for a required pose
  kCollision,             ///< a required configuration or straight line is in collision
  kPlanning,              ///< the planner found no path
  kTimeParameterization,  ///< no trajectory within the limits
  kGraspMissed,           ///< the gripper closed on nothing
  kDropped,               ///< the held object left the hand
  kSimUnstable,           ///< the simulator flagged a bad state
  kPlacement,             ///< the placed object is not where it should be
  kHalted,                ///< a motion was stopped by the behavior tree
  kTimeout,               ///< the trial ran past its simulated-time budget
  kTree,                  ///< the behavior tree failed without an action failure (a condition)
  kPrecondition,          ///< an action could not run in the state it was called in
  kTracking,              ///< a joint left the path tolerance (the controller's protective stop)
  kPathBlocked,           ///< an obstacle sensed during a motion blocks the rest of its path
  kContactForce,          ///< an external contact force past the limit (the controller's protective stop)
  kCrash,                 ///< the trial's worker process died (a signal), in both attempts
  kHang,                  ///< the wall-clock watchdog stopped the trial's worker, in both attempts
  kSpawn,                 ///< the trial's scene could not be set up (its objects did not settle): no robot ran
};
constexpr FailureKind kLastFailureKind = FailureKind::kSpawn;

/// Stable snake_case name (written into trials.jsonl).
const char* failureKindName(FailureKind kind);
/// Every kind's name but kNone's: "perception, no_grasp, ... or path_blocked".
std::string failureKindList();
/// The kind of a name failureKindName gives; kNone for an unknown name.
FailureKind failureKindFromName(const std::string& name);

struct Failure {
  std::string stage;  ///< the stage that failed, e.g. "approach"
  FailureKind kind = FailureKind::kNone;
  std::string reason;
  bool ok() const { return kind == FailureKind::kNone; }
  static Failure none() { return {}; }
};

}  // namespace mm
