// Joint trajectories sampled at the control period, their time parameterization within velocity
// and acceleration limits, and a checker of those limits.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/joint_trajectory.h"
#include "robot/robot_model.h"

namespace mm {

struct LimitScaling {
  double velocity = 1.0;      ///< fraction of the robot's velocity limits (0, 1]
  double acceleration = 1.0;  ///< fraction of the acceleration limits (0, 1]
};

/// Time-parameterizes a joint path through `waypoints` (each dim dof) with one synchronized
/// trapezoidal velocity profile per segment (all joints start and stop together; rest at each
/// waypoint), the minimum duration within the scaled limits, rounded up to whole periods.
JointTrajectory trapezoidalTrajectory(const std::vector<VecX>& waypoints, const VecX& vmax, const VecX& amax,
                                      const LimitScaling& scale, double dt);

/// Fills qd and qdd of a trajectory whose q is known, by central differences.
void differentiate(JointTrajectory& traj);

struct LimitReport {
  bool ok = true;
  double max_velocity_ratio = 0;      ///< max |qd| / vmax over samples and joints
  double max_acceleration_ratio = 0;  ///< max |qdd| / amax
  double max_jerk_ratio = 0;          ///< max |d qdd / dt| / jmax (finite differences of qdd)
  double rms_acceleration = 0;        ///< [rad/s^2] over samples and joints
  double rms_jerk = 0;                ///< [rad/s^3]
  bool positions_ok = true;
  std::string worst;                  ///< which joint, sample and quantity was worst
};

/// Checks every sample against position, velocity and acceleration limits (with a relative
/// tolerance for rounding).
LimitReport checkLimits(const JointTrajectory& traj, const RobotModel& robot, double tolerance = 1e-6);

}  // namespace mm
