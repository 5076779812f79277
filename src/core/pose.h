// Poses and small geometry helpers. T_a_b maps coordinates in frame b into frame a.
#pragma once
#include <Eigen/Geometry>
#include <vector>

namespace mm {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
using Pose = Eigen::Isometry3d;

Pose makePose(const Vec3& p, const Quat& q);
Pose makePose(const Vec3& p, const Mat3& R);
/// Rotation about z by `yaw` [rad].
Mat3 rotZ(double yaw);
Mat3 rotX(double a);
/// Yaw [rad] of a rotation's x axis projected on the world xy plane.
double yawOf(const Mat3& R);
/// Wraps an angle into (-pi, pi].
double wrapAngle(double a);
/// Angle [rad] of the relative rotation between two orientations.
double angleBetween(const Mat3& A, const Mat3& B);
/// The rotations that map a box with half sizes `half` onto itself (signed axis permutations with
/// determinant +1 whose permuted sizes agree within `tolerance`): 4 for a general box, 8 for a
/// square prism, 24 for a cube. The identity comes first.
std::vector<Mat3> boxSymmetries(const Vec3& half, double tolerance = 1e-6);
/// Least angle [rad] between A and B * S over the symmetries S of a box with half sizes `half`.
double boxSymmetricAngle(const Mat3& A, const Mat3& B, const Vec3& half);

}  // namespace mm
