#include "core/camera.h"

#include <algorithm>
#include <cmath>

namespace mm {

Vec3 CameraModel::project(const Vec3& p_world) const { return projectFromCamera(T_world_camera.inverse() * p_world); }

Vec3 CameraModel::projectFromCamera(const Vec3& p) const { return Vec3(fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy, p.z()); }

Vec3 CameraModel::unproject(double u, double v, double z) const {
  return T_world_camera * Vec3((u - cx) / fx * z, (v - cy) / fy * z, z);
}

PixelRect boxPixels(const CameraModel& cam, const Pose& T_world_box, const Vec3& lo, const Vec3& hi) {
  PixelRect r{0, 0, cam.width - 1, cam.height - 1};
  double ulo = INFINITY, uhi = -INFINITY, vlo = INFINITY, vhi = -INFINITY;
  for (double x : {lo.x(), hi.x()})
    for (double y : {lo.y(), hi.y()})
      for (double z : {lo.z(), hi.z()}) {
        const Vec3 uvz = cam.project(T_world_box * Vec3(x, y, z));
        if (!(uvz.z() > 0)) return r;
        ulo = std::min(ulo, uvz.x()), uhi = std::max(uhi, uvz.x()), vlo = std::min(vlo, uvz.y()), vhi = std::max(vhi, uvz.y());
      }
  r.u0 = static_cast<int>(std::clamp(std::floor(ulo) - 1, 0.0, cam.width - 1.0));
  r.u1 = static_cast<int>(std::clamp(std::ceil(uhi) + 1, 0.0, cam.width - 1.0));
  r.v0 = static_cast<int>(std::clamp(std::floor(vlo) - 1, 0.0, cam.height - 1.0));
  r.v1 = static_cast<int>(std::clamp(std::ceil(vhi) + 1, 0.0, cam.height - 1.0));
  return r;
}

}  // namespace mm
