#include "planning/blend.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "robot/robot_model.h"

namespace mm {

namespace {

// The blended samples i = 0..k as a trajectory (positions, velocities, accelerations summed).
JointTrajectory superpose(const JointTrajectory& a, const JointTrajectory& b, int k) {
  const int m = a.size() - 1 - k;
  const Eigen::VectorXd J = a.q.col(a.size() - 1);
  JointTrajectory c;
  c.dt = a.dt;
  c.q.resize(a.q.rows(), k + 1);
  c.qd.resize(a.q.rows(), k + 1);
  c.qdd.resize(a.q.rows(), k + 1);
  for (int i = 0; i <= k; ++i) {
    c.q.col(i) = a.q.col(m + i) + b.q.col(i) - J;
    c.qd.col(i) = a.qd.col(m + i) + b.qd.col(i);
    c.qdd.col(i) = a.qdd.col(m + i) + b.qdd.col(i);
  }
  return c;
}

// The largest |d qdd / dt| / jmax over consecutive columns [from, to] of t.
double jerkRatio(const JointTrajectory& t, int from, int to, const VecX& jmax) {
  double r = 0;
  for (int i = std::max(from, 0) + 1; i <= std::min(to, t.size() - 1); ++i)
    r = std::max(r, (((t.qdd.col(i) - t.qdd.col(i - 1)) / t.dt).cwiseAbs().cwiseQuotient(jmax)).maxCoeff());
  return r;
}

}  // namespace

int blendJunction(JointTrajectory& a, JointTrajectory& b, const RobotModel& robot, const BlendLimits& limits,
                  const std::function<bool(const VecX&)>& valid) {
  if (a.size() < 3 || b.size() < 3 || a.qd.cols() != a.size() || b.qd.cols() != b.size()) return 0;
  const VecX J = a.q.col(a.size() - 1);
  if ((b.q.col(0) - J).cwiseAbs().maxCoeff() > 1e-9) return 0;
  const Vec3 p_junction = robot.fk(J).translation();
  const VecX vmax = robot.vmax() * limits.scale.velocity, amax = robot.amax() * limits.scale.acceleration,
             jmax = robot.jmax() * limits.scale.acceleration;
  const double tol = 1 + 1e-6;
  // Only the samples within the radius can take part: a's from where it enters, b's until it leaves.
  int ka = 0, kb = 0;
  while (ka + 1 < a.size() && (robot.fk(a.q.col(a.size() - 2 - ka)).translation() - p_junction).norm() <= limits.radius) ++ka;
  while (kb + 1 < b.size() && (robot.fk(b.q.col(kb + 1)).translation() - p_junction).norm() <= limits.radius) ++kb;
  const int kmax = std::min({ka, kb, a.size() - 2, b.size() - 2});
  auto fits = [&](int k) {
    const JointTrajectory c = superpose(a, b, k);
    const int m = a.size() - 1 - k;
    for (int i = 0; i <= k; ++i) {
      if ((c.qd.col(i).cwiseAbs() - vmax * tol).maxCoeff() > 0) return false;
      if ((c.qdd.col(i).cwiseAbs() - amax * tol).maxCoeff() > 0) return false;
    }
    // Jerk: within the limit, or within what the two motions reach there on their own (the
    // sampled profiles' finite differences may already touch it).
    const double own = std::max(jerkRatio(a, m - 1, a.size() - 1, jmax), jerkRatio(b, 0, k + 1, jmax));
    std::vector<VecX> acc{a.qdd.col(m - 1)};  // a's sample before the blend, b's after it
    for (int i = 0; i <= k; ++i) acc.push_back(c.qdd.col(i));
    acc.push_back(b.qdd.col(k + 1));
    for (size_t i = 1; i < acc.size(); ++i)
      if (((acc[i] - acc[i - 1]) / a.dt).cwiseAbs().cwiseQuotient(jmax).maxCoeff() > std::max(1.0, own) * tol) return false;
    for (int i = 0; i <= k; ++i) {
      if ((robot.fk(c.q.col(i)).translation() - p_junction).norm() > limits.radius) return false;
      if (!robot.withinLimits(c.q.col(i))) return false;
    }
    for (int i = 0; i <= k; ++i)
      if (!valid(c.q.col(i))) return false;
    return true;
  };
  int k = kmax;
  while (k > 0 && !fits(k)) k = k > 8 ? k - std::max(1, k / 8) : k - 1;
  if (k <= 0) return 0;
  const JointTrajectory c = superpose(a, b, k);
  const int m = a.size() - 1 - k;
  a.q.conservativeResize(Eigen::NoChange, m + 1);
  a.qd.conservativeResize(Eigen::NoChange, m + 1);
  a.qdd.conservativeResize(Eigen::NoChange, m + 1);
  b.q.leftCols(k + 1) = c.q;
  b.qd.leftCols(k + 1) = c.qd;
  b.qdd.leftCols(k + 1) = c.qdd;
  return k;
}

}  // namespace mm
