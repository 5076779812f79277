#include "planning/cartesian.h"

#include <cmath>

#include "core/error.h"

namespace mm {

CartesianPath planCartesianLine(const RobotModel& robot, CollisionChecker& checker, const VecX& q_start,
                                const Pose& T_goal, const IkFunction& ik, const CartesianOptions& o) {
  CartesianPath p;
  const Pose T0 = robot.fk(q_start);
  const double dist = (T_goal.translation() - T0.translation()).norm();
  const double ang = angleBetween(T0.linear(), T_goal.linear());
  const int n = std::max(1, static_cast<int>(std::ceil(std::max(dist / o.step, ang / 0.05))));
  const Quat q0(T0.linear()), q1(T_goal.linear());
  p.waypoints.push_back(q_start);
  VecX q = q_start, next;
  for (int i = 1; i <= n; ++i) {
    const double s = static_cast<double>(i) / n;
    const Pose T = makePose(T0.translation() + s * (T_goal.translation() - T0.translation()), q0.slerp(s, q1));
    if (!ik(T, q, next)) {
      p.reason = "no IK solution at " + std::to_string(int(100 * s)) + "% of the line";
      return p;
    }
    if ((next - q).cwiseAbs().maxCoeff() > o.max_joint_step) {
      p.reason = "joint jump at " + std::to_string(int(100 * s)) + "% of the line (IK branch change)";
      return p;
    }
    if (!checker.isValid(next)) {
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

JointTrajectory cartesianTrajectory(const RobotModel& robot, const CartesianPath& path, const LimitScaling& scale,
                                    const CartesianOptions& o, double dt) {
  MM_DEMAND(path.ok && path.waypoints.size() >= 2);
  const auto& w = path.waypoints;
  const int m = static_cast<int>(w.size()) - 1;
  std::vector<double> s(m + 1, 0.0);  // joint-space arc length at each waypoint
  double v_s = INFINITY, a_s = INFINITY;
  for (int i = 0; i < m; ++i) {
    const VecX d = w[i + 1] - w[i];
    const double ds = std::max(d.norm(), 1e-12);
    s[i + 1] = s[i] + ds;
    for (int j = 0; j < robot.dof(); ++j) {
      const double dir = std::abs(d[j]) / ds;  // |dq_j/ds|
      if (dir > 0) {
        v_s = std::min(v_s, robot.vmax()[j] * scale.velocity / dir);
        a_s = std::min(a_s, robot.amax()[j] * scale.acceleration / dir);
      }
    }
    const double ratio = path.cartesian_length[i] / ds;  // TCP metres per joint-space radian
    if (ratio > 0) {
      v_s = std::min(v_s, o.speed / ratio);
      a_s = std::min(a_s, o.acceleration / ratio);
    }
  }
  const double S = s[m];
  JointTrajectory t;
  for (int attempt = 0; attempt < 8; ++attempt) {
    // Trapezoid (or triangle) on s.
    const double ta = std::min(v_s / a_s, std::sqrt(S / a_s));
    const double vp = a_s * ta;
    const double T = 2 * ta + (S - vp * ta) / vp;
    const int N = std::max(2, static_cast<int>(std::ceil(T / dt)) + 1);
    const double scale_t = (N - 1) * dt / T;  // stretch to whole periods
    t.dt = dt;
    t.q.resize(robot.dof(), N);
    int seg = 0;
    for (int k = 0; k < N; ++k) {
      const double tt = k * dt / scale_t;
      double sv;
      if (tt < ta) sv = 0.5 * a_s * tt * tt;
      else if (tt < T - ta) sv = 0.5 * a_s * ta * ta + vp * (tt - ta);
      else sv = S - 0.5 * a_s * std::pow(std::max(0.0, T - tt), 2);
      sv = std::clamp(sv, 0.0, S);
      if (k == N - 1) sv = S;
      while (seg < m - 1 && s[seg + 1] < sv) ++seg;
      const double f = (sv - s[seg]) / std::max(s[seg + 1] - s[seg], 1e-12);
      t.q.col(k) = w[seg] + std::clamp(f, 0.0, 1.0) * (w[seg + 1] - w[seg]);
    }
    differentiate(t);
    t.qd.col(0).setZero(), t.qd.col(N - 1).setZero();
    const LimitReport rep = checkLimits(t, robot, 1e-6);
    if (rep.max_velocity_ratio <= scale.velocity * (1 + 1e-6) + 1e-9 && rep.max_acceleration_ratio <= 1.0) break;
    v_s *= 0.7, a_s *= 0.5;  // corners of the piecewise-linear path add acceleration: slow down
  }
  return t;
}

}  // namespace mm
