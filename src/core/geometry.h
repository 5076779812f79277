// Plain geometry records shared by the simulator (which exports them) and the planner (which
// checks against them), so planning never sees MuJoCo.
#pragma once
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "core/pose.h"

namespace mm {

/// A static obstacle or an object, as the planner knows it.
struct Obstacle {
  enum class Type { kBox, kCylinder, kSphere, kCapsule };
  Type type = Type::kBox;
  Vec3 size = Vec3::Zero();  ///< box: half sizes; cylinder/capsule: (r, half length, -) along z; sphere: (r,-,-) [m]
  Pose T_world = Pose::Identity();
  std::string name;
};

/// The shape of a graspable object: a box, a cylinder along its own z axis, or a solid from a mesh
/// file (it collides as convex pieces; its half_size is its bounding box, centred on its frame).
enum class ObjectShape { kBox, kCylinder, kMesh };
inline const char* shapeName(ObjectShape s) {
  return s == ObjectShape::kCylinder ? "cylinder" : s == ObjectShape::kMesh ? "mesh" : "box";
}

/// One convex piece of a mesh object, in the object's frame: its vertices, and its faces' planes
/// (n, d) with n a unit outward normal: a point x is inside when n.x <= d for every plane [m].
struct ConvexPiece {
  std::vector<Vec3> vertices;
  std::vector<std::pair<Vec3, double>> planes;
};

/// A graspable object in the world (ground truth or perceived).
struct ObjectState {
  int index = -1;  ///< its index k (object_<k> of the trial's model)
  std::string name;
  Pose T_world_object = Pose::Identity();
  ObjectShape shape = ObjectShape::kBox;
  Vec3 half_size = Vec3::Zero();  ///< box: half sizes; cylinder: (radius, radius, half height) — its bounding box [m]
  double mass = 0;                ///< [kg] its kind's nominal mass (a real cell's item master data)
  double seen = 1;                ///< camera mode: the share of its face the camera saw (a face partly hidden: its pose is less sure)
  std::shared_ptr<const std::vector<ConvexPiece>> pieces;  ///< a mesh object's convex pieces (its model), else null
};

/// The rotation [rad] between two orientations of an object, up to its symmetries: a box's
/// (boxSymmetricAngle), a cylinder's (any turn about its axis, and end over end); a mesh object has
/// none declared (the whole rotation between them).
inline double objectSymmetricAngle(const Mat3& A, const Mat3& B, ObjectShape shape, const Vec3& half) {
  if (shape == ObjectShape::kCylinder) return std::acos(std::min(1.0, std::abs(A.col(2).dot(B.col(2)))));
  if (shape == ObjectShape::kMesh) return std::acos(std::clamp(((A.transpose() * B).trace() - 1) / 2, -1.0, 1.0));
  return boxSymmetricAngle(A, B, half);
}

}  // namespace mm
