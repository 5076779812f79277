#include "core/camera.h"

namespace mm {

Vec3 CameraModel::project(const Vec3& p_world) const {
  const Vec3 p = T_world_camera.inverse() * p_world;
  return Vec3(fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy, p.z());
}

Vec3 CameraModel::unproject(double u, double v, double z) const {
  return T_world_camera * Vec3((u - cx) / fx * z, (v - cy) / fy * z, z);
}

}  // namespace mm
