// Geometric inverse kinematics of the Franka Panda with q7 as the free parameter, after
// Y. He and S. Liu, "Analytical Inverse Kinematics for Franka Emika Panda – a Geometrical Solver
// for 7-DOF Manipulators with Unconventional Design", ICCMA 2021. Our own derivation from the
// modified DH chain (see panda_analytic.cc): for a given q7 the flange fixes the wrist frame 6,
// the shoulder-wrist distance fixes q4, the shoulder seen from frame 6 gives q5 and q6 (two
// branches), and the upper arm's direction gives q1, q2 (two branches) and q3.
#pragma once
#include <array>

#include "core/pose.h"
#include "robot/robot_model.h"

namespace mm {

class PandaAnalyticIk {
 public:
  using Joints = Eigen::Matrix<double, 7, 1>;
  /// Throws InputError when the robot's DH chain is not of the Panda's shape.
  explicit PandaAnalyticIk(const RobotModel& robot);
  /// All solutions for T_base_tcp with joint 7 at q7 [rad] (up to 8, usually 4), not yet checked
  /// against the limits of joints 1-6. `q1_singular` is used when the upper arm is vertical.
  /// Joint 6's range is wider than pi: a solution with q6 in (-pi, pi] below its lower limit
  /// is also returned with q6 + 2 pi (so up to 16 in total).
  int solve(const Pose& T_base_tcp, double q7, double q1_singular, std::array<Joints, 16>& out) const;

 private:
  double q6_lower_;
  double d1_, d3_, a4_, a5_, d5_, a7_, alpha7_;
  Pose T_tcp_inv_;  ///< (T_flange_tcp)^-1
};

}  // namespace mm
