// Closed-form inverse kinematics of the Universal Robots family (UR3/5/10/16, e-Series): 6R arms
// whose joints 2, 3 and 4 are parallel and whose wrist axes 4, 5, 6 are pairwise orthogonal, after
// K. P. Hawkins, "Analytic Inverse Kinematics for the Universal Robots UR-5/UR-10 Arms" (Georgia
// Tech, 2013). Our own derivation in the modified DH convention the robot YAML uses (see
// ur_analytic.cc): joint 1 from the wrist centre's offset along the parallel axes, joint 5 from the
// tool axis, joint 6 from where the parallel axes' direction lies in the flange frame, joints 2-4
// as a planar 2R arm plus their sum. Up to 8 solutions.
#pragma once
#include <array>

#include "core/pose.h"
#include "robot/robot_model.h"

namespace mm {

class UrAnalyticIk {
 public:
  using Joints = Eigen::Matrix<double, 6, 1>;
  /// Throws InputError when the robot's chain is not of the UR family's shape.
  explicit UrAnalyticIk(const RobotModel& robot);
  /// All solutions for T_base_tcp, each angle in (-pi, pi], not yet checked against the limits.
  /// `q6_singular` is joint 6's value where joint 5 is at 0 or pi (axes 4 and 6 aligned).
  int solve(const Pose& T_base_tcp, double q6_singular, std::array<Joints, 8>& out) const;

 private:
  double d1_, a2_, a3_, d4_, d5_, d6_;
  Pose T_tcp_inv_;  ///< (T_flange_tcp)^-1, the flange being frame 6
};

}  // namespace mm
