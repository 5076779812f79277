#include "core/joint_trajectory.h"

#include "core/error.h"

namespace mm {

JointTrajectory JointTrajectory::startingAt(const Eigen::VectorXd& q0, int samples, double dt) {
  MM_DEMAND(samples >= 1 && dt > 0);
  JointTrajectory t;
  t.dt = dt;
  t.q.resize(q0.size(), samples);
  t.qd.resize(q0.size(), samples);
  t.qdd.resize(q0.size(), samples);
  t.q.col(0) = q0;
  t.qd.col(0).setZero();
  t.qdd.col(0).setZero();
  return t;
}

void JointTrajectory::append(const JointTrajectory& o) {
  if (o.empty()) return;
  if (empty()) {
    *this = o;
    return;
  }
  MM_DEMAND(o.q.rows() == q.rows());
  const int n = size(), m = o.size() - 1;
  q.conservativeResize(Eigen::NoChange, n + m);
  qd.conservativeResize(Eigen::NoChange, n + m);
  qdd.conservativeResize(Eigen::NoChange, n + m);
  q.rightCols(m) = o.q.rightCols(m);
  qd.rightCols(m) = o.qd.rightCols(m);
  qdd.rightCols(m) = o.qdd.rightCols(m);
}

}  // namespace mm
