#include "core/pose.h"

#include <cmath>

namespace mm {

Pose makePose(const Vec3& p, const Quat& q) { return makePose(p, q.normalized().toRotationMatrix()); }

Pose makePose(const Vec3& p, const Mat3& R) {
  Pose T = Pose::Identity();
  T.linear() = R;
  T.translation() = p;
  return T;
}

Mat3 rotZ(double yaw) { return Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix(); }
Mat3 rotX(double a) { return Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix(); }

double yawOf(const Mat3& R) { return std::atan2(R(1, 0), R(0, 0)); }

double wrapAngle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a <= 0) a += 2.0 * M_PI;
  return a - M_PI;
}

double angleBetween(const Mat3& A, const Mat3& B) {
  const double c = std::clamp(((A.transpose() * B).trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c);
}

}  // namespace mm
