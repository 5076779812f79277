// A joint trajectory sampled at the control period: the data the planner produces and the joint
// trajectory controller streams.
#pragma once
#include <Eigen/Core>

namespace mm {

/// Samples k = 0..N-1 at t = k * dt: positions [rad], velocities [rad/s], accelerations [rad/s^2].
struct JointTrajectory {
  double dt = 0.002;           ///< [s]
  Eigen::MatrixXd q, qd, qdd;  ///< dim dof x N
  int size() const { return static_cast<int>(q.cols()); }
  double duration() const { return size() > 0 ? (size() - 1) * dt : 0.0; }
  bool empty() const { return size() == 0; }
  /// `samples` samples every dt, the first at rest at q0, the others to be filled.
  static JointTrajectory startingAt(const Eigen::VectorXd& q0, int samples, double dt);
  /// Appends `other` (its first sample must equal our last; it is dropped).
  void append(const JointTrajectory& other);
};

}  // namespace mm
