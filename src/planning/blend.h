// Blending one joint trajectory into the next where the first would stop (the pre-grasp and
// pre-place points, where a joint-space move meets a straight line): the end of the first and the
// start of the second run at the same time, superposed about their common rest configuration, as
// an industrial controller's blend radius rounds a waypoint (UR's blend, KUKA's approximate
// positioning). The sum is kept only where it stays within the scaled velocity, acceleration and
// jerk limits, inside the blend radius around the junction and valid (collision-free).
#pragma once
#include <functional>

#include "core/joint_trajectory.h"
#include "core/pose.h"
#include "planning/trajectory.h"

namespace mm {

class RobotModel;

struct BlendLimits {
  double radius = 0.02;   ///< [m] every blended sample's TCP within this of the junction's
  LimitScaling scale;     ///< of the robot's velocity, acceleration and jerk (scaled as acceleration) limits
};

/// `a` ends at rest where `b` starts at rest (the junction J). For an overlap of k samples the
/// last k of a's motion and the first k of b's run together: q = a[m + i] + b[i] - J (i = 0..k,
/// m = size(a) - 1 - k), velocities and accelerations likewise. Picks the largest k whose blended
/// samples keep every joint within the limits (jerk: or within what a and b themselves reach
/// there), every TCP within `radius` of J's, and pass `valid`; then cuts a to a[0..m] (it ends
/// moving: the next motion hands on) and puts the blended samples at b's start (b[0] = a[m]).
/// Returns k, 0 when nothing blends (a and b unchanged). The total duration shrinks by k periods.
int blendJunction(JointTrajectory& a, JointTrajectory& b, const RobotModel& robot, const BlendLimits& limits,
                  const std::function<bool(const VecX&)>& valid);

}  // namespace mm
