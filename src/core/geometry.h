// Plain geometry records shared by the simulator (which exports them) and the planner (which
// checks against them), so planning never sees MuJoCo.
#pragma once
#include <string>

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

/// A graspable object in the world (ground truth or perceived).
struct ObjectState {
  int index = -1;  ///< its index k (object_<k> of the trial's model)
  std::string name;
  Pose T_world_object = Pose::Identity();
  Vec3 half_size = Vec3::Zero();  ///< box half sizes [m]
  double mass = 0;                ///< [kg] its kind's nominal mass (a real cell's item master data)
};

}  // namespace mm
