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

std::vector<Mat3> boxSymmetries(const Vec3& half, double tolerance) {
  std::vector<Mat3> out;
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : perms)
    for (int signs = 0; signs < 8; ++signs) {
      Mat3 R = Mat3::Zero();
      bool fits = true;
      for (int col = 0; col < 3; ++col) {
        // Column col is the image of the box's axis col: the axis p[col], with a sign.
        R(p[col], col) = (signs >> col) & 1 ? -1.0 : 1.0;
        fits = fits && std::abs(half[col] - half[p[col]]) <= tolerance;
      }
      if (fits && R.determinant() > 0) out.push_back(R);
    }
  return out;  // {0,1,2} with no sign flip, the identity, comes first
}

double boxSymmetricAngle(const Mat3& A, const Mat3& B, const Vec3& half) {
  double best = INFINITY;
  for (const Mat3& S : boxSymmetries(half)) best = std::min(best, angleBetween(A, B * S));
  return best;
}

}  // namespace mm
