// Jerk-limited motion through waypoints without stopping (the problem Ruckig solves with its
// intermediate waypoints): per joint, a piecewise-constant-jerk profile between the states (p, v,
// a) at consecutive waypoints, all joints of a segment synchronized to the slowest one; the
// velocities at the waypoints chosen to reduce the total time (accelerations zero there), then
// shrunk where the motion, which leaves the straight segments, is not valid.
//
// One joint, (p0, v0, a0) -> (pf, vf, af) within |v| <= V, |a| <= A, |j| <= J: the profiles are
// "change to (vp, 0), cruise at vp, change to (vf, af)", each change the fastest jerk-limited one
// (the acceleration ramps to a peak, holds, ramps back). With zero accelerations at the ends the
// time-optimal profile has this form (the peak velocity has zero acceleration; it cruises only at
// +-V); with nonzero ones the family is a good one but not always the optimum (a profile whose
// acceleration dips without reaching zero is not in it). For a prescribed duration T the reachable
// distances form an interval (the reachable set of a linear system under convex bounds is convex)
// that the family spans except in rare short-T cases, where T grows by a period.
// References: T. Kroeger, "On-Line Trajectory Generation in Robotic Systems", Springer 2010;
// L. Berscheid and T. Kroeger, "Jerk-limited Real-time Trajectory Generation with Arbitrary Target
// States", RSS 2021 (Ruckig). Our solver is numeric (scan and bisection), not their closed forms.
#pragma once
#include <array>
#include <functional>
#include <vector>

#include "core/joint_trajectory.h"
#include "planning/trajectory.h"

namespace mm {

/// One joint's profile: up to 7 phases of constant jerk from (p0, v0, a0).
struct JerkProfile {
  double p0 = 0, v0 = 0, a0 = 0;
  std::array<double, 7> duration{};  ///< [s]
  std::array<double, 7> jerk{};      ///< [rad/s^3]
  int phases = 0;
  double totalDuration() const;
  /// State at time t (beyond the end the motion continues at the final acceleration).
  void eval(double t, double& p, double& v, double& a) const;
};

/// Shortest duration (within the family above) from (0, v0, a0) to (d, vf, af) within V, A, J
/// (all > 0); infinite if an end state is not feasible (|a| <= A, |v| + a^2 / 2J <= V).
double jerkMinTime(double d, double v0, double a0, double vf, double af, double V, double A, double J);
inline double jerkMinTime(double d, double v0, double vf, double V, double A, double J) {
  return jerkMinTime(d, v0, 0, vf, 0, V, A, J);
}

/// A profile of exactly duration T from (p0, v0, a0) to (pf, vf, af), or false if none was found.
bool jerkProfileForDuration(double p0, double pf, double v0, double a0, double vf, double af, double V, double A,
                            double J, double T, JerkProfile& out);
inline bool jerkProfileForDuration(double p0, double pf, double v0, double vf, double V, double A, double J, double T,
                                   JerkProfile& out) {
  return jerkProfileForDuration(p0, pf, v0, 0, vf, 0, V, A, J, T, out);
}

/// Jerk-limited, resting at every waypoint: per segment, all joints follow one normalized double-S
/// (7-phase) profile, the shortest within the scaled velocity, acceleration and jerk limits of
/// every joint (Biagiotti & Melchiorri, "Trajectory Planning for Automatic Machines and Robots",
/// 2008, sec. 3.4), so the motion stays on the straight segments. `jmax` is scaled like `amax`.
JointTrajectory jerkLimitedTrajectory(const std::vector<VecX>& waypoints, const VecX& vmax, const VecX& amax,
                                      const VecX& jmax, const LimitScaling& scale, double dt);

struct JerkWaypointResult {
  JointTrajectory trajectory;  ///< empty if the limits cannot be met
  int interior_waypoints = 0;  ///< waypoints between the first and the last
  int stops = 0;               ///< interior waypoints where the robot rests
  int shrinks = 0;             ///< waypoint velocities reduced because a sample was invalid
  std::vector<int> waypoint_samples;  ///< sample index of each (distinct) waypoint
};

/// Jerk-limited trajectory through `waypoints`, sampled every dt (every waypoint falls on a
/// sample). `valid` (may be empty) is asked about every sample of a segment that leaves the
/// straight line; segments that rest at both ends stay on it (one synchronized double-S). Velocity
/// and acceleration limits are scaled by `scale`, jerk limits by scale.acceleration.
JerkWaypointResult jerkLimitedThroughWaypoints(const std::vector<VecX>& waypoints, const VecX& vmax, const VecX& amax,
                                               const VecX& jmax, const LimitScaling& scale, double dt,
                                               const std::function<bool(const VecX&)>& valid = {});

}  // namespace mm
