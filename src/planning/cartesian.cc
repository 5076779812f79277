#include "planning/cartesian.h"

#include <cmath>

#include "core/error.h"
#include "planning/jerk.h"

namespace mm {

void CartesianOptions::declare(ConfigArchive& a) {
  a.value("cartesian_speed", speed, {0.01, 1.0}, "m/s", "TCP speed limit on straight-line moves");
  a.value("cartesian_acceleration", acceleration, {0.05, 5.0}, "m/s^2", "TCP acceleration limit on straight-line moves");
  a.value("cartesian_jerk", jerk, {1.0, 10000.0}, "m/s^3",
          "TCP jerk limit on straight-line moves (a double-S profile; Franka's published Cartesian limit is 6500)");
}

CartesianPath planCartesianLine(const RobotModel& robot, CollisionChecker& checker, const VecX& q_start,
                                const Pose& T_goal, const IkFunction& ik, const CartesianOptions& o) {
  CartesianPath p;
  const Pose T0 = robot.fk(q_start);
  const double dist = (T_goal.translation() - T0.translation()).norm();
  const double ang = angleBetween(T0.linear(), T_goal.linear());
  const int n = std::max(1, static_cast<int>(std::ceil(std::max(dist / o.step, ang / 0.05))));
  const Quat q0(T0.linear()), q1(T_goal.linear());
  p.T_start = T0;
  p.T_goal = T_goal;
  p.waypoints.push_back(q_start);
  VecX q = q_start, next;
  for (int i = 1; i <= n; ++i) {
    const double s = static_cast<double>(i) / n;
    const Pose T = makePose(T0.translation() + s * (T_goal.translation() - T0.translation()), q0.slerp(s, q1));
    if (!ik(T, q, next)) {
      p.kind = FailureKind::kIk;
      p.reason = "no IK solution at " + std::to_string(int(100 * s)) + "% of the line";
      return p;
    }
    if ((next - q).cwiseAbs().maxCoeff() > o.max_joint_step) {
      p.kind = FailureKind::kIk;
      p.reason = "joint jump at " + std::to_string(int(100 * s)) + "% of the line (IK branch change)";
      return p;
    }
    if (!checker.isValid(next)) {
      p.kind = FailureKind::kCollision;
      p.reason = "collision at " + std::to_string(int(100 * s)) + "% of the line (" + checker.lastCollision() + ")";
      return p;
    }
    p.cartesian_length.push_back(dist / n);
    p.waypoints.push_back(next);
    q = next;
  }
  p.ok = true;
  return p;
}

JointTrajectory cartesianTrajectory(const RobotModel& robot, const CartesianPath& path, const IkFunction& ik,
                                    const LimitScaling& scale, const CartesianOptions& o, double dt, const VecX* q_from) {
  MM_DEMAND(path.ok && path.waypoints.size() >= 2);
  const Vec3 p0 = path.T_start.translation(), p1 = path.T_goal.translation();
  const Quat q0(path.T_start.linear()), q1(path.T_goal.linear());
  const double L = (p1 - p0).norm();
  const double ang = angleBetween(path.T_start.linear(), path.T_goal.linear());
  // Distance along the line, with rotation counted as 0.1 m per rad so pure turns move too.
  const double S = std::max(L, 0.1 * ang);
  double v = o.speed, a = o.acceleration, j = o.jerk;
  JointTrajectory t;
  t.dt = dt;
  double slowed_by = 1.0, was = 0.0;  // the last slow-down and the worst ratio before it
  for (int attempt = 0; attempt < 12; ++attempt) {
    // The shortest double-S from rest to rest over S (jerk ramps, acceleration held, cruise), then
    // the profile of that duration rounded up to whole periods (slightly slower, never faster).
    const double T = jerkMinTime(S, 0, 0, v, a, j);
    if (!std::isfinite(T)) return {};
    int N = std::max(2, static_cast<int>(std::ceil(T / dt - 1e-9)) + 1);
    JerkProfile profile;
    while (!jerkProfileForDuration(0, S, 0, 0, v, a, j, (N - 1) * dt, profile))
      if (++N > static_cast<int>(std::ceil(2 * T / dt)) + 3) return {};
    t.q.resize(robot.dof(), N);
    t.q.col(0) = q_from ? *q_from : path.waypoints.front();
    VecX q = t.q.col(0), next;
    bool ok = true;
    for (int k = 1; k < N && ok; ++k) {
      double s, sd, sdd;
      profile.eval(k * dt, s, sd, sdd);
      const double f = k == N - 1 ? 1.0 : std::clamp(s / S, 0.0, 1.0);
      const Pose Tk = makePose(p0 + f * (p1 - p0), q0.slerp(f, q1));
      ok = ik(Tk, q, next);
      if (ok) t.q.col(k) = q = next;
    }
    if (!ok) return {};
    differentiate(t);
    const LimitReport rep = checkLimits(t, robot, 0.0);
    const double rv = rep.max_velocity_ratio / scale.velocity, ra = rep.max_acceleration_ratio / scale.acceleration;
    if (rep.positions_ok && rv <= 1.0 && ra <= 1.0) return t;
    // No timing mends a joint out of its range, nor a joint path that jumps (the IK at a joint's
    // limit or switching branch between samples): there slowing down by k does not divide the
    // ratios by k, and each try would take k times the samples of the last.
    const double worst = std::max(rv, std::sqrt(ra));
    if (!rep.positions_ok || (attempt > 0 && worst > was / std::sqrt(slowed_by))) return {};
    // Slow down by what the worst joint needs (velocity scales with v, acceleration with v^2 and a,
    // jerk with v^3).
    const double k = worst * 1.05;
    slowed_by = k;
    was = worst;
    v /= k;
    a /= k * k;
    j /= k * k * k;
  }
  return {};
}

}  // namespace mm
