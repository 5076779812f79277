#include "kinematics/chain.h"

#include <cmath>

#include "core/error.h"

namespace mm {

FastChain::FastChain(const RobotModel& robot) : n_(robot.dof()) {
  MM_DEMAND(n_ <= kMaxDof);
  for (int k = 0; k < n_; ++k) {
    R_pre_[k] = robot.jointOrigin(k).linear();
    p_pre_[k] = robot.jointOrigin(k).translation();
    axis_[k] = robot.jointAxis(k);
    z_axis_[k] = (axis_[k] - Vec3::UnitZ()).norm() < 1e-12;
  }
  R_tcp_ = robot.T_flange_tcp().linear();
  p_tcp_ = robot.T_flange_tcp().translation();
}

namespace {

// R <- R * Rot(axis, q), with the common z-axis case done by columns.
inline void rotate(Mat3& R, bool z, const Vec3& axis, double q) {
  const double c = std::cos(q), s = std::sin(q);
  if (z) {
    const Vec3 x = R.col(0), y = R.col(1);
    R.col(0) = c * x + s * y;
    R.col(1) = c * y - s * x;
  } else {
    R = R * Eigen::AngleAxisd(q, axis).toRotationMatrix();
  }
}

}  // namespace

void FastChain::fk(const double* q, Mat3& R, Vec3& p) const {
  R.setIdentity();
  p.setZero();
  for (int k = 0; k < n_; ++k) {
    p += R * p_pre_[k];
    R = R * R_pre_[k];
    rotate(R, z_axis_[k], axis_[k], q[k]);
  }
  p += R * p_tcp_;
  R = R * R_tcp_;
}

void FastChain::fkJacobian(const double* q, Mat3& R, Vec3& p, Jac& J) const {
  J.resize(6, n_);
  std::array<Vec3, kMaxDof> z, o;
  R.setIdentity();
  p.setZero();
  for (int k = 0; k < n_; ++k) {
    p += R * p_pre_[k];
    R = R * R_pre_[k];
    rotate(R, z_axis_[k], axis_[k], q[k]);
    z[k] = z_axis_[k] ? Vec3(R.col(2)) : Vec3(R * axis_[k]);
    o[k] = p;
  }
  p += R * p_tcp_;
  R = R * R_tcp_;
  for (int k = 0; k < n_; ++k) {
    J.block<3, 1>(0, k) = z[k].cross(p - o[k]);
    J.block<3, 1>(3, k) = z[k];
  }
}

Eigen::Matrix<double, 6, 1> poseError(const Mat3& R_target, const Vec3& p_target, const Mat3& R, const Vec3& p) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = p_target - p;
  // Rotation vector of R_target R^T (log map), robust near 0 and pi.
  const Mat3 Re = R_target * R.transpose();
  const double cos_a = std::clamp((Re.trace() - 1.0) * 0.5, -1.0, 1.0);
  const Vec3 v(Re(2, 1) - Re(1, 2), Re(0, 2) - Re(2, 0), Re(1, 0) - Re(0, 1));
  const double sin_a2 = v.norm();  // 2 sin(angle)
  if (cos_a > 0.999999) {
    e.tail<3>() = 0.5 * v;  // small angle: sin a ~ a
  } else if (cos_a > -0.99) {
    const double a = std::acos(cos_a);
    e.tail<3>() = v * (a / sin_a2);
  } else {
    // Near pi: the axis from the symmetric part.
    const double a = std::acos(cos_a);
    const Mat3 B = 0.5 * (Re + Re.transpose()) - cos_a * Mat3::Identity();
    int i;
    B.diagonal().maxCoeff(&i);
    Vec3 axis = B.col(i) / std::sqrt(std::max(B(i, i), 1e-300));
    if (axis.dot(v) < 0) axis = -axis;
    e.tail<3>() = axis.normalized() * a;
  }
  return e;
}

}  // namespace mm
