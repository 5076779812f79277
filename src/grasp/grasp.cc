#include "grasp/grasp.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mm {

void GraspOptions::declare(ConfigArchive& a) {
  a.value("depth", depth, {-0.02, 0.02}, "m", "TCP height above the object's center at the grasp");
  a.list("yaw_offsets", yaw_offsets, {-1.0, 1.0}, "rad",
         "yaw samples around each face-aligned grasp (0: aligned); every aligned candidate is tried before an offset one");
  a.value("side_grasps", side_grasps, "also grasp tall upright objects from the side (the hand horizontal)");
  a.value("side_min_height", side_min_height, {0.02, 0.5}, "m", "upright objects at least this tall get side grasps");
  a.value("torque_weight", torque_weight, {0.0, 1000.0}, "1/m",
          "score lost per metre between the centre of mass and the grasp axis (the lever gravity and acceleration turn the object about)");
  a.value("tilt_weight", tilt_weight, {0.0, 10.0}, "1/rad", "score lost per radian of the hand's tilt from pointing down");
}

Mat3 topDownRotation(double psi) { return rotZ(psi) * rotX(M_PI); }

double forceClosureMargin(const Vec3& p1, const Vec3& n1, const Vec3& p2, const Vec3& n2, double mu) {
  const Vec3 d = p2 - p1;
  if (d.norm() < 1e-12) return -M_PI;
  const Vec3 u = d.normalized();
  auto angle = [](const Vec3& a, const Vec3& b) { return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)); };
  // The force at p1 pushes along +u into the object, at p2 along -u.
  return std::atan(mu) - std::max(angle(u, n1), angle(-u, n2));
}

bool lineThroughObject(const ObjectState& o, const Vec3& p_world, const Vec3& y_world, double& t1, double& t2, Vec3& n1, Vec3& n2) {
  const Mat3 R = o.T_world_object.linear();
  const Vec3 p = o.T_world_object.inverse() * p_world, y = R.transpose() * y_world;
  const Vec3& h = o.half_size;
  Vec3 in = Vec3::Zero(), out = Vec3::Zero();
  if (o.shape == ObjectShape::kMesh && o.pieces) {
    // Each convex piece clips the line by its planes; the fingers meet the outermost entry and exit.
    bool hit = false;
    for (const ConvexPiece& piece : *o.pieces) {
      double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
      Vec3 n_lo = Vec3::Zero(), n_hi = Vec3::Zero();
      bool miss = false;
      for (const auto& [n, d] : piece.planes) {
        const double ny = n.dot(y), gap = d - n.dot(p);
        if (std::abs(ny) < 1e-12) {
          if (gap < 0) miss = true;
          continue;
        }
        const double t = gap / ny;
        if (ny < 0 && t > lo) lo = t, n_lo = n;
        if (ny > 0 && t < hi) hi = t, n_hi = n;
      }
      if (miss || !(lo < hi)) continue;
      if (!hit || lo < t1) t1 = lo, in = n_lo;
      if (!hit || hi > t2) t2 = hi, out = n_hi;
      hit = true;
    }
    if (!hit) return false;
    n1 = R * in;
    n2 = R * out;
    return true;
  }
  t1 = -std::numeric_limits<double>::infinity();
  t2 = std::numeric_limits<double>::infinity();
  // Slabs: all three axes for a box, the caps for a cylinder.
  for (int a = (o.shape == ObjectShape::kCylinder ? 2 : 0); a < 3; ++a) {
    if (std::abs(y[a]) < 1e-12) {
      if (std::abs(p[a]) > h[a]) return false;
      continue;
    }
    double ta = (-h[a] - p[a]) / y[a], tb = (h[a] - p[a]) / y[a];
    Vec3 na = -Vec3::Unit(a), nb = Vec3::Unit(a);
    if (ta > tb) std::swap(ta, tb), std::swap(na, nb);
    if (ta > t1) t1 = ta, in = na;
    if (tb < t2) t2 = tb, out = nb;
  }
  if (o.shape == ObjectShape::kCylinder) {  // the side: (px + t yx)^2 + (py + t yy)^2 = r^2
    const double r = h.x(), A = y.x() * y.x() + y.y() * y.y(), B = 2 * (p.x() * y.x() + p.y() * y.y()),
                 C = p.x() * p.x() + p.y() * p.y() - r * r;
    if (A < 1e-12) {
      if (C > 0) return false;
    } else {
      const double disc = B * B - 4 * A * C;
      if (disc < 0) return false;
      const double ta = (-B - std::sqrt(disc)) / (2 * A), tb = (-B + std::sqrt(disc)) / (2 * A);
      auto radial = [&](double t) { return Vec3(p.x() + t * y.x(), p.y() + t * y.y(), 0).normalized(); };
      if (ta > t1) t1 = ta, in = radial(ta);
      if (tb < t2) t2 = tb, out = radial(tb);
    }
  }
  if (!(t1 < t2)) return false;
  n1 = R * in;
  n2 = R * out;
  return true;
}

namespace {

// Distance from point p to an obstacle, taken as its bounding box in its own frame (0 inside).
double distanceToBox(const Vec3& p, const Obstacle& o) {
  const Vec3 local = o.T_world.inverse() * p;
  Vec3 h = o.size;
  if (o.type == Obstacle::Type::kCylinder || o.type == Obstacle::Type::kCapsule) h = Vec3(o.size.x(), o.size.x(), o.size.y());
  else if (o.type != Obstacle::Type::kBox) h = Vec3::Constant(o.size.x());
  const Vec3 d = (local.cwiseAbs() - h).cwiseMax(0.0);
  return d.norm();
}

// An obstacle's bounding box in its own frame.
Vec3 boundingHalf(const Obstacle& o) {
  if (o.type == Obstacle::Type::kBox) return o.size;
  if (o.type == Obstacle::Type::kSphere) return Vec3::Constant(o.size.x());
  return Vec3(o.size.x(), o.size.x(), o.size.y() + (o.type == Obstacle::Type::kCapsule ? o.size.x() : 0.0));
}

// The highest point of an obstacle's bounding box, and whether its footprint (the box seen from
// above) overlaps the horizontal rectangle centred at c with unit axes u, v and half sizes hu, hv.
// Separating axes: the rectangle's two and the box's projected edges (the footprint of a tilted
// box is taken as the rectangle of its horizontal extent along its own projected axes, a cover).
bool footprintOverlaps(const Obstacle& o, const Vec3& c, const Vec3& u, const Vec3& v, double hu, double hv, double& top) {
  const Mat3 R = o.T_world.linear();
  const Vec3 h = boundingHalf(o);
  top = o.T_world.translation().z();
  for (int a = 0; a < 3; ++a) top += std::abs(R(2, a)) * h[a];
  // Footprint corners: the eight box corners projected on the table plane.
  std::vector<Vec3> corners;
  for (int k = 0; k < 8; ++k) {
    const Vec3 s((k & 1) ? 1 : -1, (k & 2) ? 1 : -1, (k & 4) ? 1 : -1);
    Vec3 q = o.T_world * Vec3(s.cwiseProduct(h));
    q.z() = 0;
    corners.push_back(q);
  }
  const Vec3 c0(c.x(), c.y(), 0);
  std::vector<Vec3> rect;
  for (double su : {-1.0, 1.0})
    for (double sv : {-1.0, 1.0}) rect.push_back(c0 + su * hu * u + sv * hv * v);
  std::vector<Vec3> axes{u, v};
  for (int a = 0; a < 3; ++a) {
    Vec3 d(R(0, a), R(1, a), 0);
    if (d.norm() > 1e-6) axes.push_back(Vec3(-d.y(), d.x(), 0).normalized()), axes.push_back(d.normalized());
  }
  for (const Vec3& n : axes) {
    double lo1 = INFINITY, hi1 = -INFINITY, lo2 = INFINITY, hi2 = -INFINITY;
    for (const Vec3& q : corners) lo1 = std::min(lo1, q.dot(n)), hi1 = std::max(hi1, q.dot(n));
    for (const Vec3& q : rect) lo2 = std::min(lo2, q.dot(n)), hi2 = std::max(hi2, q.dot(n));
    if (hi1 < lo2 || hi2 < lo1) return false;
  }
  return true;
}

// The score terms every candidate shares: force closure, the pad area covered, the torque arm.
void assess(GraspCandidate& g, const ObjectState& target, const GraspOptions& o) {
  const Mat3 Rt = g.T_world_tcp.linear();
  const Vec3 p = g.T_world_tcp.translation(), x = Rt.col(0), y = Rt.col(1), z = Rt.col(2);
  double t1, t2;
  Vec3 n1, n2;
  if (!lineThroughObject(target, p, y, t1, t2, n1, n2)) {
    g.closure_margin = -M_PI;
    g.rejected = "the fingers close past the object";
  } else {
    g.closure_margin = forceClosureMargin(p + t1 * y, -n1, p + t2 * y, -n2, o.friction);
    if (g.closure_margin <= 0) g.rejected = "not in force closure (a contact's normal outside its friction cone)";
  }
  // Pad coverage: the pad's points whose closing line meets the object.
  constexpr int kU = 5, kV = 11;
  int hits = 0;
  for (int i = 0; i < kU; ++i)
    for (int j = 0; j < kV; ++j) {
      const double a = -o.pad_half_width + (i + 0.5) * 2 * o.pad_half_width / kU;
      const double b = o.pad_z_min + (j + 0.5) * (o.pad_z_max - o.pad_z_min) / kV;
      double s1, s2;
      Vec3 m1, m2;
      if (lineThroughObject(target, p + a * x + b * z, y, s1, s2, m1, m2)) ++hits;
    }
  const double pad_area = 2 * o.pad_half_width * (o.pad_z_max - o.pad_z_min);
  g.contact_area = pad_area * hits / (kU * kV);
  const Vec3 d = target.T_world_object.translation() - p;
  g.torque_arm = (d - d.dot(y) * y).norm();
  const double tilt = std::acos(std::clamp(-z.z(), -1.0, 1.0));
  g.score += o.closure_weight * std::max(g.closure_margin, 0.0) + o.area_weight * hits / (kU * kV) - o.torque_weight * g.torque_arm -
             o.tilt_weight * tilt;
}

// The open fingertips' clearance to the nearest neighbour.
double fingerClearance(const Vec3& p, const Vec3& y, double top, const std::vector<Obstacle>& neighbours, const GraspOptions& o) {
  double clearance = 0.05;
  for (const Obstacle& n : neighbours)
    for (double side : {1.0, -1.0}) {
      const Vec3 tip = p + side * o.finger_reach * y;
      const Vec3 tip_high(tip.x(), tip.y(), std::min(tip.z(), top));
      clearance = std::min(clearance, distanceToBox(tip_high, n));
    }
  return clearance;
}

void topDown(const ObjectState& target, double preferred_yaw, const std::vector<Obstacle>& neighbours, const GraspOptions& o,
             std::vector<GraspCandidate>& out) {
  const Mat3 R = target.T_world_object.linear();
  const bool cylinder = target.shape == ObjectShape::kCylinder;
  // The object's axis nearest the vertical is its "height"; its upper face is grasped.
  int up = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(R.col(a).z()) > std::abs(R.col(up).z())) up = a;
  if (cylinder) up = 2;
  const double cos_tilt = std::abs(R.col(up).z());
  const bool upright = cos_tilt > std::cos(15.0 * M_PI / 180);
  if (cos_tilt < std::cos(50.0 * M_PI / 180) || (cylinder && !upright)) return;
  const Vec3 normal = R.col(up).z() > 0 ? Vec3(R.col(up)) : Vec3(-R.col(up));  // the upper face's
  const Vec3 c = target.T_world_object.translation();
  const double top = c.z() + target.half_size[up];
  // Upright: the TCP at the centre's height (plus depth), but no deeper than the hand body
  // allows below the top, nor the fingertips below the bottom.
  double z_tcp = c.z() + o.depth;
  if (upright) {
    z_tcp = std::max(z_tcp, top - (o.hand_back - 0.01));
    z_tcp = std::max(z_tcp, c.z() - target.half_size[up] + o.pad_z_max + 0.002);
  }
  auto add = [&](GraspCandidate g, const Mat3& Rt, const Vec3& p, double offset) {
    g.T_world_tcp = makePose(p, Rt);
    g.clearance = fingerClearance(p, Rt.col(1), top, neighbours, o);
    g.score = -std::abs(wrapAngle(g.yaw - preferred_yaw)) + o.clearance_weight * g.clearance - o.offset_penalty * std::abs(offset);
    assess(g, target, o);
    out.push_back(g);
  };
  if (cylinder) {  // any yaw grasps the same: sampled every 30 degrees from the preferred one
    const double width = 2 * target.half_size.x();
    if (width > o.max_opening - o.width_margin) return;
    for (int k = 0; k < 12; ++k) {
      GraspCandidate g;
      g.yaw = wrapAngle(preferred_yaw + k * M_PI / 6);
      g.width = width;
      add(g, topDownRotation(g.yaw), Vec3(c.x(), c.y(), z_tcp), 0.0);
    }
    return;
  }
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
        Vec3 p(c.x(), c.y(), z_tcp);
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
        add(g, Rt, p, offset);
      }
  }
}

// Side grasps of a tall upright object: approached horizontally along `a` (pointing from the
// object to the pre-grasp), the fingers closing horizontally, both ways up.
void side(const ObjectState& target, const Vec3& robot_base, const std::vector<Obstacle>& neighbours, const GraspOptions& o,
          std::vector<GraspCandidate>& out) {
  const Mat3 R = target.T_world_object.linear();
  const bool cylinder = target.shape == ObjectShape::kCylinder;
  if (R.col(2).z() < std::cos(15.0 * M_PI / 180)) return;  // upright only (its own z up)
  const Vec3 c = target.T_world_object.translation();
  const double height = 2 * target.half_size.z(), top = c.z() + target.half_size.z();
  if (height < o.side_min_height) return;
  const Vec3 to_base = Vec3(robot_base.x() - c.x(), robot_base.y() - c.y(), 0).normalized();
  const double azimuth0 = std::atan2(to_base.y(), to_base.x());
  std::vector<std::pair<Vec3, double>> approaches;  // direction, half width across the fingers
  if (cylinder) {
    for (int k = 0; k < o.side_azimuths; ++k) {
      const double phi = azimuth0 + 2 * M_PI * k / o.side_azimuths;
      approaches.push_back({Vec3(std::cos(phi), std::sin(phi), 0), target.half_size.x()});
    }
  } else {
    for (int a = 0; a < 2; ++a)
      for (double s : {1.0, -1.0}) {
        Vec3 d = s * R.col(a);
        d.z() = 0;
        approaches.push_back({d.normalized(), target.half_size[1 - a]});
      }
  }
  for (const auto& [a, half_width] : approaches) {
    const double width = 2 * half_width;
    if (width > o.max_opening - o.width_margin) continue;
    double t1, t2;
    Vec3 n1, n2;
    // The hand body must stay outside the object: its depth along the approach.
    if (!lineThroughObject(target, c, a, t1, t2, n1, n2) || t2 > o.hand_back - 0.005) continue;
    // As low as the hand's underside clears every top it sweeps over, from the grasp to the
    // pre-grasp (the hand body and the fingers, across its width); never below the centre of mass.
    const Vec3 across = Vec3::UnitZ().cross(a);
    const double reach = o.approach_distance + o.hand_back + 0.06;
    const Vec3 mid = c + a * (reach / 2);
    double floor_z = -INFINITY;
    for (const Obstacle& n : neighbours) {
      double t;
      if (footprintOverlaps(n, mid, a, across, reach / 2, o.hand_half_width, t)) floor_z = std::max(floor_z, t);
    }
    const double z = std::max(c.z(), floor_z + o.hand_half_thickness + 0.005);
    if (z > top - o.pad_half_width - 0.002) continue;  // the pads would not sit on the object
    const double phi = std::atan2(a.y(), a.x());
    for (double up : {1.0, -1.0}) {  // the TCP's x up or down
      GraspCandidate g;
      g.type = GraspType::kSide;
      g.yaw = phi;
      g.width = width;
      g.approach = a;
      Mat3 Rt;
      Rt.col(2) = -a;
      Rt.col(0) = up * Vec3::UnitZ();
      Rt.col(1) = Rt.col(2).cross(Rt.col(0));
      const Vec3 p(c.x(), c.y(), z);
      g.T_world_tcp = makePose(p, Rt);
      g.clearance = fingerClearance(p, Rt.col(1), top, neighbours, o);
      g.score = -std::abs(wrapAngle(phi - azimuth0)) + o.clearance_weight * g.clearance;
      assess(g, target, o);
      out.push_back(g);
    }
  }
}

}  // namespace

std::vector<GraspCandidate> graspCandidates(const ObjectState& target, double preferred_yaw, const Vec3& robot_base,
                                            const std::vector<Obstacle>& neighbours, const GraspOptions& o) {
  std::vector<GraspCandidate> out;
  topDown(target, preferred_yaw, neighbours, o, out);
  if (o.side_grasps) side(target, robot_base, neighbours, o, out);
  std::stable_sort(out.begin(), out.end(), [](const auto& x, const auto& y) {
    if (x.rejected.empty() != y.rejected.empty()) return x.rejected.empty();
    return x.score > y.score;
  });
  return out;
}

}  // namespace mm
