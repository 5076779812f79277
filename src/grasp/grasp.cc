#include "grasp/grasp.h"

#include <algorithm>
#include <cmath>

namespace mm {

void GraspOptions::declare(ConfigArchive& a) {
  a.value("depth", depth, {-0.02, 0.02}, "m", "TCP height above the object's center at the grasp");
  a.list("yaw_offsets", yaw_offsets, {-1.0, 1.0}, "rad",
         "yaw samples around each face-aligned grasp (0: aligned); every aligned candidate is tried before an offset one");
}

Mat3 topDownRotation(double psi) { return rotZ(psi) * rotX(M_PI); }

namespace {

// Distance from point p to an axis-aligned-in-its-frame box (0 inside).
double distanceToBox(const Vec3& p, const Obstacle& o) {
  const Vec3 local = o.T_world.inverse() * p;
  Vec3 h = o.size;
  if (o.type != Obstacle::Type::kBox) h = Vec3::Constant(o.size.x());
  const Vec3 d = (local.cwiseAbs() - h).cwiseMax(0.0);
  return d.norm();
}

}  // namespace

std::vector<GraspCandidate> topDownGrasps(const ObjectState& target, double preferred_yaw,
                                          const std::vector<Obstacle>& neighbours, const GraspOptions& o) {
  std::vector<GraspCandidate> out;
  const Mat3 R = target.T_world_object.linear();
  // The object's axis nearest the vertical is its "height"; its upper face is grasped.
  int up = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(R.col(a).z()) > std::abs(R.col(up).z())) up = a;
  const double cos_tilt = std::abs(R.col(up).z());
  if (cos_tilt < std::cos(50.0 * M_PI / 180)) return out;
  const bool upright = cos_tilt > std::cos(15.0 * M_PI / 180);
  const Vec3 normal = R.col(up).z() > 0 ? Vec3(R.col(up)) : Vec3(-R.col(up));  // the upper face's
  const Vec3 c = target.T_world_object.translation();
  const double top = c.z() + target.half_size[up];
  for (int a = 0; a < 3; ++a) {
    if (a == up) continue;
    const Vec3 axis = R.col(a);  // fingers close along this axis
    const double width = 2 * target.half_size[a];
    if (width > o.max_opening - o.width_margin) continue;
    const double theta = std::atan2(axis.y(), axis.x());
    for (double flip : {M_PI / 2, -M_PI / 2})  // both finger orientations
      for (double offset : o.yaw_offsets) {
      GraspCandidate g;
      g.yaw = wrapAngle(theta + flip + offset);
      g.width = width;
      Mat3 Rt = topDownRotation(g.yaw);
      Vec3 p(c.x(), c.y(), c.z() + o.depth);
      if (!upright) {
        // Tilted: the TCP's z into the upper face, the fingers closing along the object's axis
        // (turned by the offset about the face normal), as topDownRotation does for an upright one.
        const Vec3 y = Eigen::AngleAxisd(offset, normal) * ((flip > 0 ? 1.0 : -1.0) * axis);
        const Vec3 z = -normal;
        Rt.col(0) = y.cross(z);
        Rt.col(1) = y;
        Rt.col(2) = z;
        p = c + o.depth * normal;
        g.approach = normal;
      }
      g.T_world_tcp = makePose(p, Rt);
      // Clearance: the open fingertips' outer points to the nearest neighbour.
      const Vec3 y = Rt.col(1);
      g.clearance = 0.05;
      for (const Obstacle& n : neighbours)
        for (double side : {1.0, -1.0}) {
          const Vec3 tip = p + side * o.finger_reach * y;
          const Vec3 tip_high(tip.x(), tip.y(), std::min(tip.z(), top));
          g.clearance = std::min(g.clearance, distanceToBox(tip_high, n));
        }
      g.score = -std::abs(wrapAngle(g.yaw - preferred_yaw)) + o.clearance_weight * g.clearance -
                o.offset_penalty * std::abs(offset);
      out.push_back(g);
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const auto& x, const auto& y) { return x.score > y.score; });
  return out;
}

}  // namespace mm
