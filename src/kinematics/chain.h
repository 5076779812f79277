// FastChain: forward kinematics and the geometric Jacobian of a RobotModel's arm with fixed-size
// storage (up to 8 joints), no heap allocation, computed in one pass. The IK solvers' hot loop.
#pragma once
#include <Eigen/Core>
#include <array>

#include "core/pose.h"
#include "robot/robot_model.h"

namespace mm {

class FastChain {
 public:
  static constexpr int kMaxDof = 8;
  using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxDof, 1>;
  using Jac = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxDof>;

  explicit FastChain(const RobotModel& robot);
  int dof() const { return n_; }

  /// TCP orientation R and position p [m] in the base frame for q (dim dof) [rad].
  void fk(const double* q, Mat3& R, Vec3& p) const;
  /// Also the geometric Jacobian (rows: linear; angular) in the base frame, dim 6 x dof.
  void fkJacobian(const double* q, Mat3& R, Vec3& p, Jac& J) const;

 private:
  int n_ = 0;
  std::array<Mat3, kMaxDof> R_pre_;
  std::array<Vec3, kMaxDof> p_pre_;
  std::array<Vec3, kMaxDof> axis_;
  std::array<bool, kMaxDof> z_axis_;
  Mat3 R_tcp_;
  Vec3 p_tcp_;
};

/// Pose error of (R, p) relative to a target: position [m] and rotation vector [rad], base frame.
Eigen::Matrix<double, 6, 1> poseError(const Mat3& R_target, const Vec3& p_target, const Mat3& R, const Vec3& p);

}  // namespace mm
