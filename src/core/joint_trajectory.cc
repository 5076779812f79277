#include "core/joint_trajectory.h"

#include "core/error.h"

namespace mm {

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
