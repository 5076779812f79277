// Time-optimal path following under joint velocity and acceleration limits, on the path of
// T. Kunz and M. Stilman, "Time-Optimal Trajectory Generation for Path Following with Bounded
// Acceleration and Velocity", RSS 2012 (MoveIt 2's default time parameterization): the waypoints
// joined by straight segments with circular blends that stay within `max_deviation` of each
// waypoint, so the robot does not stop at them.
//
// The phase-plane problem is theirs: maximize the path speed sdot(s) subject to, for every joint
// i, |q_i'(s) sddot + q_i''(s) sdot^2| <= a_i and |q_i'(s) sdot| <= v_i (the acceleration bounds
// also cap sdot on the blends, where q'' != 0). It is solved here by integrating x = sdot^2 on a
// fine arc-length grid: forward at the largest feasible path acceleration, then backward at the
// smallest, the minimum of the two passes and the velocity limit curve giving the profile (the
// paper's switching points are where the passes meet). The result is sampled every `dt` and
// checked against the limits; if discretization oversteps them, the internal limits tighten.
#pragma once
#include <vector>

#include "core/joint_trajectory.h"
#include "planning/trajectory.h"
#include "robot/robot_model.h"

namespace mm {

struct TotgOptions {
  double max_deviation = 0.05;  ///< [rad] blends stay this close to each waypoint (0: stop at them)
  double grid = 5e-4;           ///< [rad] arc-length step of the phase-plane integration (blends: 1/10 of it)
};

/// Empty when no trajectory within the limits could be made (it says so, it does not guess).
JointTrajectory totgTrajectory(const std::vector<VecX>& waypoints, const RobotModel& robot, const LimitScaling& scale,
                               double dt, const TotgOptions& options = {});

}  // namespace mm
