// Our fast collision checker: the robot's collision primitives covered by spheres, checked against
// the world's primitives with exact sphere-vs-box (sphere, capsule, cylinder) distances.
//
// Conservative by construction: every robot primitive, padded the way FCL pads it (a box's sizes
// and a cylinder's radius and length grown, so corners reach further than a rounded margin), lies
// inside the union of its spheres, so a state the spheres call free is free for FCL too
// (tests/planning/collision_test checks this on 100,000 random states). Self-collision uses the
// unpadded shapes' spheres, as FCL's self check does. Covering: a cylinder of radius r and length L gets spheres on its axis
// at spacing s <= r (ends included) of radius sqrt(r^2 + (s/2)^2); a sphere is itself; a box is
// split into cells no smaller than its middle dimension (so mostly along its long axis), each
// covered by the sphere through its corners.
//
// Layout: sphere centers in structure-of-arrays form, transformed per link; a link's bounding
// sphere is tested first (broadphase); the first contact ends the check. No allocation per check.
#include <array>
#include <cmath>

#include "core/error.h"
#include "planning/collision.h"

namespace mm {
namespace {

constexpr double kCell = 0.02;  // [m] smallest box cell edge

struct LocalSphere {
  int link;
  Vec3 c;
  double r;
  int shape = 0;  // index of the primitive it covers
};

// FCL's padding of a robot primitive (collision_fcl.cc): sizes grown, not rounded. A convex hull
// is covered as its bounding box in its own frame (it contains the hull, so the cover stays
// conservative against FCL's hull).
CollisionShape padded(CollisionShape s, double pad) {
  if (s.type == CollisionShape::Type::kConvex) {
    s.type = CollisionShape::Type::kBox;
    s.size = s.hull->upper - s.hull->lower;
    s.T_link_shape = s.T_link_shape * makePose(0.5 * (s.hull->upper + s.hull->lower), Mat3::Identity());
    s.hull.reset();
  }
  switch (s.type) {
    case CollisionShape::Type::kSphere: s.size.x() += pad; break;
    case CollisionShape::Type::kCylinder: s.size.x() += pad, s.size.y() += 2 * pad; break;
    case CollisionShape::Type::kBox: s.size += Vec3::Constant(2 * pad); break;
    case CollisionShape::Type::kConvex: break;
  }
  return s;
}

void coverShape(const CollisionShape& s, std::vector<LocalSphere>& out) {
  if (s.type == CollisionShape::Type::kConvex) return coverShape(padded(s, 0.0), out);
  const Pose& T = s.T_link_shape;
  switch (s.type) {
    case CollisionShape::Type::kConvex: break;
    case CollisionShape::Type::kSphere:
      out.push_back({s.link, T.translation(), s.size.x()});
      break;
    case CollisionShape::Type::kCylinder: {
      const double r = s.size.x(), L = s.size.y();
      const int n = std::max(2, static_cast<int>(std::ceil(L / r)) + 1);
      const double step = L / (n - 1);
      const double R = std::sqrt(r * r + 0.25 * step * step);
      for (int k = 0; k < n; ++k) out.push_back({s.link, T * Vec3(0, 0, -0.5 * L + k * step), R});
      break;
    }
    case CollisionShape::Type::kBox: {
      std::array<double, 3> sorted = {s.size.x(), s.size.y(), s.size.z()};
      std::sort(sorted.begin(), sorted.end());
      const double edge = std::max(kCell, sorted[1]);
      std::array<int, 3> n;
      Vec3 cell;
      for (int a = 0; a < 3; ++a) {
        n[a] = std::max(1, static_cast<int>(std::ceil(s.size[a] / edge - 1e-9)));
        cell[a] = s.size[a] / n[a];
      }
      const double R = 0.5 * cell.norm();
      for (int i = 0; i < n[0]; ++i)
        for (int j = 0; j < n[1]; ++j)
          for (int k = 0; k < n[2]; ++k) {
            const Vec3 local = -0.5 * s.size + Vec3((i + 0.5) * cell.x(), (j + 0.5) * cell.y(), (k + 0.5) * cell.z());
            out.push_back({s.link, T * local, R});
          }
      break;
    }
  }
}

// World primitives, in the form the distance tests want.
struct WorldBox {
  Mat3 Rt;  // world-to-box rotation
  Vec3 p, h;
  double bound;
  std::string name;
  Vec3 lo, hi;  // world axis-aligned bounds
};
struct WorldSegment {  // capsules, spheres (zero length) and cylinders (as their capsule: conservative)
  Vec3 a, b;
  double r;
  std::string name;
};

double pointSegmentDistanceSq(const Vec3& c, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((c - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - c).squaredNorm();
}

class SphereChecker final : public GeometricChecker {
 public:
  SphereChecker(const RobotModel& robot, const PlanningScene& scene, double pad, bool confirm_with_fcl)
      : GeometricChecker(robot), scene_(scene) {
    const int nl = static_cast<int>(robot.links().size());
    world_.build(robot, nl, pad);
    self_.build(robot, nl, 0.0);
    // The held object: a box on the hand, covered the same way.
    hand_ = robot.handLink();
    const double apad = std::isnan(scene.attached_padding) ? pad : scene.attached_padding;
    for (const PlanningScene::AttachedBox& a : attachedBoxes(scene)) {
      CollisionShape box;
      box.type = CollisionShape::Type::kBox;
      box.size = 2 * (a.half + Vec3::Constant(apad)).cwiseMax(1e-3);
      box.link = hand_;
      box.T_link_shape = makePose(Vec3(0, 0, robot.spec().tcp_offset), Mat3::Identity()) * a.T_tcp_box;
      std::vector<LocalSphere> held;
      coverShape(box, held);
      for (const auto& s : held) held_local_.push_back(s.c), held_radius_.push_back(s.r);
    }
    for (const auto& o : scene.obstacles) {
      if (std::find(scene.ignore.begin(), scene.ignore.end(), o.name) != scene.ignore.end()) continue;
      if (o.type == Obstacle::Type::kBox) {
        const Vec3 ext = o.T_world.linear().cwiseAbs() * o.size;  // half extents of the world AABB
        boxes_.push_back({o.T_world.linear().transpose(), o.T_world.translation(), o.size, o.size.norm(), o.name,
                          o.T_world.translation() - ext, o.T_world.translation() + ext});
      } else {
        const double r = o.size.x();
        const double half = o.type == Obstacle::Type::kSphere ? 0.0 : o.size.y();
        const Vec3 axis = o.T_world.linear().col(2);
        // A cylinder is inside the capsule of the same radius and length: conservative.
        segments_.push_back({o.T_world.translation() - half * axis, o.T_world.translation() + half * axis, r, o.name});
      }
    }
    // Self pairs: the same link pairs FCL checks (more than one frame apart, not touching at home),
    // as sphere index pairs.
    if (confirm_with_fcl) fcl_ = makeFclChecker(robot, scene, pad);
    self_links_ = selfCollisionLinkPairs(robot, scene.finger_opening);
  }

  bool collisionFree(const VecX& q) override {
    robot_.linkPoses(q, scene_.finger_opening, T_);
    ++stamp_;
    bool hit = worldHit() || heldHit() || selfHit();
    if (hit && fcl_) {  // confirm: the spheres over-approximate, FCL is exact
      hit = !fcl_->isValid(q);
      if (hit) last_ = fcl_->lastCollision();
    }
    return !hit;
  }

 private:
  bool worldHit() {
    Spheres& w = world_;
    const int nl = static_cast<int>(w.link_bound.size());
    for (int l = 0; l < nl; ++l) {
      if (robot_.links()[l].frame == 0 || w.first[l] == w.first[l + 1]) continue;  // the base stands on the table
      const Vec3 lc = T_[l] * w.link_center[l];
      const double lr = w.link_bound[l];
      for (const WorldBox& b : boxes_) {
        // Broadphase: the link's bounding sphere, then each primitive's, against the box's AABB.
        const Vec3 g = (b.lo - lc).cwiseMax(lc - b.hi).cwiseMax(0.0);
        if (g.squaredNorm() >= lr * lr) continue;
        for (int k = w.link_shapes[l]; k < w.link_shapes[l + 1]; ++k) {
          const Vec3& sc = w.shapeCenter(k, T_[l], stamp_);
          const Vec3 gs = (b.lo - sc).cwiseMax(sc - b.hi).cwiseMax(0.0);
          if (gs.squaredNorm() >= w.shape_bound[k] * w.shape_bound[k]) continue;
          w.placeShape(k, T_[l], stamp_);
          for (int i = w.shape_first[k]; i < w.shape_first[k + 1]; ++i) {
            const Vec3 d = b.Rt * (Vec3(w.x[i], w.y[i], w.z[i]) - b.p);
            const Vec3 e = (d.cwiseAbs() - b.h).cwiseMax(0.0);
            if (e.squaredNorm() < w.r[i] * w.r[i]) {
              last_ = robot_.links()[l].name + " / " + b.name;
              return true;
            }
          }
        }
      }
      for (const WorldSegment& s : segments_) {
        const double rs = lr + s.r;
        if (pointSegmentDistanceSq(lc, s.a, s.b) >= rs * rs) continue;
        for (int k = w.link_shapes[l]; k < w.link_shapes[l + 1]; ++k) w.placeShape(k, T_[l], stamp_);
        for (int i = w.first[l]; i < w.first[l + 1]; ++i) {
          const double r = w.r[i] + s.r;
          if (pointSegmentDistanceSq(Vec3(w.x[i], w.y[i], w.z[i]), s.a, s.b) < r * r) {
            last_ = robot_.links()[l].name + " / " + s.name;
            return true;
          }
        }
      }
    }
    return false;
  }

  bool heldIgnores(const std::string& name) const {
    return std::find(scene_.attached_ignore.begin(), scene_.attached_ignore.end(), name) != scene_.attached_ignore.end();
  }

  bool heldHit() {
    if (held_local_.empty()) return false;
    const Pose& T = T_[hand_];
    for (size_t i = 0; i < held_local_.size(); ++i) {
      const Vec3 c = T * held_local_[i];
      for (const WorldBox& b : boxes_) {
        if (heldIgnores(b.name)) continue;
        const Vec3 e = ((b.Rt * (c - b.p)).cwiseAbs() - b.h).cwiseMax(0.0);
        if (e.squaredNorm() < held_radius_[i] * held_radius_[i]) {
          last_ = "held object / " + b.name;
          return true;
        }
      }
      for (const WorldSegment& s : segments_) {
        if (heldIgnores(s.name)) continue;
        const double r = held_radius_[i] + s.r;
        if (pointSegmentDistanceSq(c, s.a, s.b) < r * r) {
          last_ = "held object / " + s.name;
          return true;
        }
      }
    }
    return false;
  }

  bool selfHit() {
    Spheres& s = self_;
    for (const auto& [la, lb] : self_links_) {
      const double rb = s.link_bound[la] + s.link_bound[lb];
      if ((T_[la] * s.link_center[la] - T_[lb] * s.link_center[lb]).squaredNorm() > rb * rb) continue;  // broadphase
      for (int ka = s.link_shapes[la]; ka < s.link_shapes[la + 1]; ++ka)
        for (int kb = s.link_shapes[lb]; kb < s.link_shapes[lb + 1]; ++kb) {
          const double rk = s.shape_bound[ka] + s.shape_bound[kb];
          if ((s.shapeCenter(ka, T_[la], stamp_) - s.shapeCenter(kb, T_[lb], stamp_)).squaredNorm() >= rk * rk) continue;
          s.placeShape(ka, T_[la], stamp_);
          s.placeShape(kb, T_[lb], stamp_);
          for (int i = s.shape_first[ka]; i < s.shape_first[ka + 1]; ++i)
            for (int j = s.shape_first[kb]; j < s.shape_first[kb + 1]; ++j) {
              const double dx = s.x[i] - s.x[j], dy = s.y[i] - s.y[j], dz = s.z[i] - s.z[j];
              const double r = s.r[i] + s.r[j];
              if (dx * dx + dy * dy + dz * dz < r * r) {
                last_ = robot_.links()[la].name + " / " + robot_.links()[lb].name;
                return true;
              }
            }
        }
    }
    return false;
  }

  // One sphere set in structure-of-arrays form, grouped by link.
  struct Spheres {
    std::vector<int> first, link_of;  // spheres of link l: [first[l], first[l+1])
    // Primitives: spheres [shape_first[k], shape_first[k+1]) cover primitive k, bounded by a sphere
    // of radius shape_bound[k] about shape_center[k] (link frame); link l owns primitives
    // [link_shapes[l], link_shapes[l+1]).
    std::vector<int> shape_first, link_shapes;
    std::vector<Vec3> shape_center, shape_world;
    std::vector<double> shape_bound;
    std::vector<unsigned> shape_placed;
    std::vector<Vec3> local;
    std::vector<double> r, x, y, z, link_bound;
    std::vector<Vec3> link_center;  // local
    void build(const RobotModel& robot, int nl, double pad) {
      std::vector<LocalSphere> all;
      int shape = 0;
      for (const auto& s : robot.collisionShapes()) {
        const size_t from = all.size();
        coverShape(padded(s, pad), all);
        for (size_t i = from; i < all.size(); ++i) all[i].shape = shape;
        ++shape;
      }
      std::stable_sort(all.begin(), all.end(), [](auto& a, auto& b) { return a.link < b.link; });
      // Primitive ranges and bounds (spheres of one primitive are contiguous after the sort).
      link_shapes.assign(nl + 1, 0);
      for (size_t i = 0; i < all.size(); ++i) {
        if (i == 0 || all[i].shape != all[i - 1].shape) {
          shape_first.push_back(static_cast<int>(i));
          ++link_shapes[all[i].link + 1];
        }
      }
      shape_first.push_back(static_cast<int>(all.size()));
      for (int l = 0; l < nl; ++l) link_shapes[l + 1] += link_shapes[l];
      const size_t ns = shape_first.size() - 1;
      shape_center.assign(ns, Vec3::Zero());
      shape_bound.assign(ns, 0.0);
      for (size_t k = 0; k < ns; ++k) {
        for (int i = shape_first[k]; i < shape_first[k + 1]; ++i) shape_center[k] += all[i].c;
        shape_center[k] /= (shape_first[k + 1] - shape_first[k]);
        for (int i = shape_first[k]; i < shape_first[k + 1]; ++i)
          shape_bound[k] = std::max(shape_bound[k], (all[i].c - shape_center[k]).norm() + all[i].r);
      }
      shape_world.assign(ns, Vec3::Zero());
      shape_placed.assign(ns, 0);
      first.assign(nl + 1, 0);
      for (const auto& s : all) ++first[s.link + 1];
      for (int l = 0; l < nl; ++l) first[l + 1] += first[l];
      // Each link's bounding sphere, centered on its spheres' centroid (tighter than the origin).
      link_bound.assign(nl, 0.0);
      link_center.assign(nl, Vec3::Zero());
      std::vector<int> count(nl, 0);
      for (const auto& s : all) link_center[s.link] += s.c, ++count[s.link];
      for (int l = 0; l < nl; ++l)
        if (count[l]) link_center[l] /= count[l];
      for (const auto& s : all) {
        local.push_back(s.c);
        r.push_back(s.r);
        link_of.push_back(s.link);
        link_bound[s.link] = std::max(link_bound[s.link], (s.c - link_center[s.link]).norm() + s.r);
      }
      x.resize(all.size()), y.resize(all.size()), z.resize(all.size());
      placed.assign(ns, 0);
    }
    std::vector<unsigned> placed;  // the check stamp at which each primitive's spheres were placed
    // Transforms primitive k's spheres to the world, once per check.
    void placeShape(int k, const Pose& P, unsigned stamp) {
      if (placed[k] == stamp) return;
      placed[k] = stamp;
      const Mat3& R = P.linear();
      const Vec3& t = P.translation();
      for (int i = shape_first[k]; i < shape_first[k + 1]; ++i) {
        const Vec3 c = R * local[i] + t;
        x[i] = c.x(), y[i] = c.y(), z[i] = c.z();
      }
    }
    // Primitive k's bounding-sphere center in the world, once per check.
    const Vec3& shapeCenter(int k, const Pose& P, unsigned stamp) {
      if (shape_placed[k] != stamp) {
        shape_placed[k] = stamp;
        shape_world[k] = P * shape_center[k];
      }
      return shape_world[k];
    }
  };

  PlanningScene scene_;
  Spheres world_, self_;
  std::vector<Vec3> held_local_;
  std::vector<double> held_radius_;
  std::vector<WorldBox> boxes_;
  std::vector<WorldSegment> segments_;
  std::vector<std::pair<int, int>> self_links_;
  std::unique_ptr<CollisionChecker> fcl_;
  int hand_ = -1;
  std::vector<Pose> T_;
  unsigned stamp_ = 0;
};

}  // namespace

SphereModel coverRobot(const RobotModel& robot, double padding) {
  std::vector<LocalSphere> all;
  for (const auto& s : robot.collisionShapes()) coverShape(padded(s, padding), all);
  SphereModel m;
  for (const auto& s : all) {
    m.link.push_back(s.link);
    m.local.push_back(s.c);
    m.radius.push_back(s.r);
  }
  return m;
}

double sphereSceneDistance(const PlanningScene& scene, const Vec3& c, double r, Vec3& gradient) {
  double best = INFINITY;
  gradient.setZero();
  for (const auto& o : scene.obstacles) {
    if (std::find(scene.ignore.begin(), scene.ignore.end(), o.name) != scene.ignore.end()) continue;
    double d;
    Vec3 g;
    if (o.type == Obstacle::Type::kBox) {
      const Mat3& R = o.T_world.linear();
      const Vec3 local = R.transpose() * (c - o.T_world.translation());
      const Vec3 outside = (local.cwiseAbs() - o.size).cwiseMax(0.0);
      if (outside.squaredNorm() > 0) {  // outside: distance to the nearest box point
        const Vec3 nearest = local.cwiseMax(-o.size).cwiseMin(o.size);
        const Vec3 v = local - nearest;
        d = v.norm() - r;
        g = R * (v / v.norm());
      } else {  // inside: the nearest face, negative
        const Vec3 depth = o.size - local.cwiseAbs();
        int a;
        depth.minCoeff(&a);
        Vec3 n = Vec3::Zero();
        n[a] = local[a] >= 0 ? 1.0 : -1.0;
        d = -depth[a] - r;
        g = R * n;
      }
    } else {
      const double half = o.type == Obstacle::Type::kSphere ? 0.0 : o.size.y();
      const Vec3 axis = o.T_world.linear().col(2);
      const Vec3 a = o.T_world.translation() - half * axis, b = o.T_world.translation() + half * axis;
      const Vec3 ab = b - a;
      const double t = ab.squaredNorm() > 0 ? std::clamp((c - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
      const Vec3 v = c - (a + t * ab);
      const double len = v.norm();
      d = len - o.size.x() - r;
      g = len > 1e-12 ? Vec3(v / len) : Vec3::UnitZ();
    }
    if (d < best) best = d, gradient = g;
  }
  return best;
}

std::unique_ptr<CollisionChecker> makeSphereChecker(const RobotModel& robot, const PlanningScene& scene, double padding,
                                                    bool confirm_with_fcl) {
  return std::make_unique<SphereChecker>(robot, scene, padding, confirm_with_fcl);
}

}  // namespace mm
