// The time parameterizations by name, with one policy for motion that leaves the planned path:
// the planner validated straight segments between waypoints; a method that blends or curves
// through waypoints has its samples checked, and backs off where one is invalid.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "core/joint_trajectory.h"
#include "planning/trajectory.h"
#include "robot/robot_model.h"

namespace mm {

/// "trapezoidal" and "jerk_limited_stop" rest at every waypoint on the straight segments;
/// "jerk_limited" passes through waypoints with jerk-limited profiles; "totg" follows a blended
/// path time-optimally under velocity and acceleration limits (no jerk limit).
const std::vector<std::string>& timeParameterizationNames();

struct TimedPath {
  JointTrajectory trajectory;  ///< empty if the method could not meet the limits
  int interior_waypoints = 0;
  int stops = 0;       ///< interior waypoints where the robot rests
  int backoffs = 0;    ///< times an invalid sample made the method back off (slower or closer to the path)
  LimitReport limits;  ///< the output checked against the robot's (unscaled) limits
  std::string failure; ///< why the trajectory is empty, if it is
};

/// `valid` (may be empty) is asked about samples that leave the straight segments. TOTG backs off
/// to smaller blends (0.05, 0.01 rad, then none); jerk_limited to lower speeds at the waypoints.
/// Every output is checked against the robot's position, velocity and acceleration limits, and
/// the jerk-limited ones against its jerk limits; an output that fails is not returned.
TimedPath timeParameterize(const std::string& method, const std::vector<VecX>& path, const RobotModel& robot,
                           const LimitScaling& scale, double dt, const std::function<bool(const VecX&)>& valid = {});

}  // namespace mm
