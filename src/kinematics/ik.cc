#include "kinematics/ik.h"

#include <Eigen/Dense>
#include <cmath>

namespace mm {
namespace {

// Pose error of T relative to the target: (position; rotation vector), in the base frame.
Eigen::Matrix<double, 6, 1> poseError(const Pose& target, const Pose& T) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = target.translation() - T.translation();
  const Eigen::AngleAxisd aa(target.linear() * T.linear().transpose());
  e.tail<3>() = aa.axis() * aa.angle();
  return e;
}

}  // namespace

IkResult solveIkDls(const RobotModel& robot, const Pose& target, const VecX& seed, Rng& rng, const IkOptions& o) {
  IkResult r;
  const int n = robot.dof();
  if (seed.size() != n || !seed.allFinite() || !target.matrix().allFinite()) {
    r.status = IkStatus::kInvalidInput;
    r.reason = "non-finite target or seed of the wrong size";
    return r;
  }
  const VecX lo = robot.lower().array() + o.limit_margin, hi = robot.upper().array() - o.limit_margin;
  VecX q(n), dq(n);
  Jacobian J;
  Eigen::Matrix<double, 6, 6> A;
  double best = INFINITY;
  for (int attempt = 0; attempt < o.max_attempts; ++attempt) {
    ++r.attempts;
    if (attempt == 0) {
      q = seed.cwiseMax(lo).cwiseMin(hi);
    } else {
      for (int i = 0; i < n; ++i) q[i] = rng.uniform(lo[i], hi[i]);
    }
    for (int it = 0; it < o.max_iterations; ++it) {
      ++r.iterations;
      const Eigen::Matrix<double, 6, 1> e = poseError(target, robot.fk(q));
      const double ep = e.head<3>().norm(), er = e.tail<3>().norm();
      if (ep + er < best) best = ep + er, r.position_error = ep, r.rotation_error = er;
      if (ep < o.tol_position && er < o.tol_rotation) {
        r.status = IkStatus::kSuccess;
        r.q = q;
        r.position_error = ep;
        r.rotation_error = er;
        return r;
      }
      robot.jacobian(q, J);
      A.noalias() = J * J.transpose();
      A.diagonal().array() += o.damping * o.damping;
      dq.noalias() = J.transpose() * A.ldlt().solve(e);
      const double step = dq.cwiseAbs().maxCoeff();
      if (step > 0.5) dq *= 0.5 / step;  // trust region [rad]
      q = (q + dq).cwiseMax(lo).cwiseMin(hi);
      if (step < 1e-12) break;
    }
  }
  r.status = IkStatus::kNoSolution;
  r.reason = "no solution within " + std::to_string(o.max_attempts) + " attempts (best error " +
             std::to_string(r.position_error * 1000) + " mm, " + std::to_string(r.rotation_error) + " rad)";
  return r;
}

}  // namespace mm
