// Straight-line Cartesian motion of the TCP (approach, lift, place, retreat), by IK at small steps
// from the current configuration, and its time parameterization.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/failure.h"
#include "planning/collision.h"
#include "planning/trajectory.h"

namespace mm {

/// IK callback: solve for `target` near `seed`; return false when there is no solution.
using IkFunction = std::function<bool(const Pose& target, const VecX& seed, VecX& out)>;

struct CartesianOptions {
  /// Keys cartesian_speed, cartesian_acceleration (section "motion").
  void declare(ConfigArchive& a);
  double step = 0.005;          ///< [m] Cartesian spacing of waypoints
  double max_joint_step = 0.1;  ///< [rad] larger jumps between waypoints mean a branch flip
  double speed = 0.2;           ///< [m/s] TCP speed limit
  double acceleration = 1.0;    ///< [m/s^2] TCP acceleration limit
  double jerk = 500.0;          ///< [m/s^3] TCP jerk limit (Franka's Cartesian limit: 6500)
};

struct CartesianPath {
  bool ok = false;
  std::vector<VecX> waypoints;
  std::vector<double> cartesian_length;  ///< [m] length of each segment
  Pose T_start = Pose::Identity(), T_goal = Pose::Identity();
  FailureKind kind = FailureKind::kNone;  ///< why it failed: kIk (no solution, branch change) or kCollision
  std::string reason;
};

/// From configuration q_start (whose TCP pose is the line's start) to T_goal, position linear and
/// orientation slerped. Each waypoint is IK-solved from the previous one and collision-checked.
CartesianPath planCartesianLine(const RobotModel& robot, CollisionChecker& checker, const VecX& q_start,
                                const Pose& T_goal, const IkFunction& ik, const CartesianOptions& options);

/// One jerk-limited double-S profile in the TCP's distance along the line (within the TCP speed,
/// acceleration and jerk limits), sampled every `dt` with IK from the previous sample, so the joint motion is smooth;
/// then checked against the scaled joint limits and slowed down until it holds. Empty when IK
/// fails along the way (the path's waypoints already proved the line feasible), when a joint
/// leaves its range, or when slowing down does not lower the joints' speeds as it should (the
/// joint path jumps between samples, which no timing mends). It starts at
/// `q_from` when given (where the previous motion left the arm: the same TCP pose as the path's
/// start, perhaps elsewhere in a redundant arm's null space), else at the path's first waypoint.
JointTrajectory cartesianTrajectory(const RobotModel& robot, const CartesianPath& path, const IkFunction& ik,
                                    const LimitScaling& scale, const CartesianOptions& options, double dt,
                                    const VecX* q_from = nullptr);

}  // namespace mm
