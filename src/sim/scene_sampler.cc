#include "sim/scene_sampler.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <cmath>
#include <filesystem>

#include "core/error.h"

namespace mm {

void SpawnOptions::declare(ConfigArchive& a) {
  a.value("count_min", count_min, {1, 100}, "", "fewest objects in the bin");
  a.value("count_max", count_max, {1, 100}, "", "most objects in the bin");
  a.path("catalogue", catalogue, "the object catalogue (YAML: kinds by name with shape, size, mass, friction, condim, colour; a colour palette); paths as for robot");
  a.list("kinds", kinds, {}, "the catalogue's kinds a trial's objects are drawn from, uniformly and independently per object (one kind: no draw)");
  a.value("pool", pool, {0, 100}, "",
          "objects in the model at least: those out of play parked on the floor at the scene's object_park (copies of the first kind). "
          "0: the model holds only the objects in play. Kept to measure what a parked pool costs (tools/bench)");
  a.value("wall_margin", wall_margin, {0.0, 0.1}, "m", "object centers keep this far from the bin walls");
  a.value("min_spacing", min_spacing, {0.05, 0.3}, "m", "least distance between object centers");
  a.value("min_gap", min_gap, {0.0, 0.3}, "m",
          "least gap between upright objects' outlines seen from above (boxes' rectangles, cylinders' circles), and half of it "
          "between an outline and the bin's edges; 0: min_spacing and wall_margin only");
  a.value("settle_time", settle_time, {0.0, 5.0}, "s", "simulated settling after spawning");
  a.value("drop", drop,
         "drop the objects into the bin from above in random orientations (layers of three, wall_margin from the walls), "
         "so that they touch, lean and stack; false: upright, min_spacing apart");
  a.enter("generated");
  generated.declare(a);
  a.leave();
}

void SpawnOptions::resolve(const std::string& file) {
  // The experiment's loader resolved the path (a file's value against the file, --set's against
  // the working directory, the default against the project root); so did the benches.
  loaded = loadObjectCatalogue(std::filesystem::path(catalogue).lexically_normal().string());
  if (generated.enabled() && generated.max_extent < generated.max_width)
    throw InputError(file, "objects.generated.max_extent (" + std::to_string(generated.max_extent) +
                               " m) is less than max_width (" + std::to_string(generated.max_width) + " m): expected at least as long");
  if (kinds.empty()) throw InputError(file, "objects.kinds: expected at least one kind of " + loaded.file);
  for (const std::string& k : kinds)
    if (!loaded.find(k)) {
      std::string names;
      for (const std::string& n : loaded.names()) names += (names.empty() ? "" : ", ") + n;
      throw InputError(file, "objects.kinds: '" + k + "' is not in the catalogue " + loaded.file + " (expected one of " + names + ")");
    }
}

namespace {

// A rotation drawn uniformly (a normalized 4-D Gaussian is a uniform unit quaternion).
Mat3 uniformRotation(Rng& rng) {
  Eigen::Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
  return q.normalized().toRotationMatrix();
}

// An upright object's outline seen from above: a rectangle (box) or a circle (cylinder).
struct Footprint {
  Vec2 c;
  double yaw = 0;
  ObjectShape shape = ObjectShape::kBox;
  Vec2 half;  // box: half sizes; cylinder: (r, r)
  Vec2 axis(int a) const { return a == 0 ? Vec2(std::cos(yaw), std::sin(yaw)) : Vec2(-std::sin(yaw), std::cos(yaw)); }
  std::array<Vec2, 4> corners() const {
    std::array<Vec2, 4> v;
    for (int k = 0; k < 4; ++k) v[k] = c + (k & 1 ? 1 : -1) * half.x() * axis(0) + (k & 2 ? 1 : -1) * half.y() * axis(1);
    return v;
  }
  // Distance from p to the outline's inside (0 inside).
  double distance(const Vec2& p) const {
    if (shape == ObjectShape::kCylinder) return std::max(0.0, (p - c).norm() - half.x());
    const Vec2 d = p - c;
    const Vec2 local(std::abs(d.dot(axis(0))) - half.x(), std::abs(d.dot(axis(1))) - half.y());
    return local.cwiseMax(0.0).norm();
  }
};

// The gap between two outlines (0 when they touch or overlap). Two convex outlines that do not
// overlap are nearest at a corner of one of them (rectangles), or along the line of centres
// (circles).
double footprintGap(const Footprint& a, const Footprint& b) {
  if (a.shape == ObjectShape::kCylinder && b.shape == ObjectShape::kCylinder)
    return std::max(0.0, (a.c - b.c).norm() - a.half.x() - b.half.x());
  if (a.shape == ObjectShape::kCylinder) return std::max(0.0, b.distance(a.c) - a.half.x());
  if (b.shape == ObjectShape::kCylinder) return std::max(0.0, a.distance(b.c) - b.half.x());
  // Separating axes: the rectangles' edge normals.
  for (const Footprint* f : {&a, &b})
    for (int k = 0; k < 2; ++k) {
      const Vec2 n = f->axis(k);
      double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
      int i = 0;
      for (const Footprint* g : {&a, &b}) {
        for (const Vec2& v : g->corners()) lo[i] = std::min(lo[i], v.dot(n)), hi[i] = std::max(hi[i], v.dot(n));
        ++i;
      }
      if (hi[0] < lo[1] || hi[1] < lo[0]) {  // separated: the nearest corner
        double d = INFINITY;
        for (const Vec2& v : a.corners()) d = std::min(d, b.distance(v));
        for (const Vec2& v : b.corners()) d = std::min(d, a.distance(v));
        return d;
      }
    }
  return 0.0;
}

}  // namespace

double outlineGap(ObjectShape shape_a, const Vec3& half_a, const Pose& T_a, ObjectShape shape_b, const Vec3& half_b, const Pose& T_b) {
  auto fp = [](ObjectShape s, const Vec3& h, const Pose& T) {
    return Footprint{T.translation().head<2>(), yawOf(T.linear()), s, h.head<2>()};
  };
  return footprintGap(fp(shape_a, half_a, T_a), fp(shape_b, half_b, T_b));
}

SpawnResult spawnObjects(SimWorld& w, const RobotModel& robot, const Pose& T_region, const Vec3& half, Rng& rng,
                         const SpawnOptions& options) {
  SpawnOptions resolved;
  if (options.loaded.kinds.empty()) {
    resolved = options;
    resolved.resolve("(spawn options)");
  }
  const SpawnOptions& o = options.loaded.kinds.empty() ? resolved : options;
  SpawnResult r;
  const int count = o.count_min + static_cast<int>(rng.below(o.count_max - o.count_min + 1));
  // The objects in play (a kind drawn per object when there are several), then the parked pool.
  // Generated objects: the round's set drawn from its own seed, taken from the scene's stream
  // (the set does not depend on how many draws placing it takes).
  std::vector<ObjectKind> objects;
  if (o.generated.enabled()) {
    objects = generateObjectSet(rng.next(), count, o.generated);
    for (const ObjectKind& k : objects) r.grades.push_back(k.grade);
    for (int i = count; i < o.pool; ++i) objects.push_back(objects.front());
  }
  for (int i = static_cast<int>(objects.size()); i < std::max(count, o.pool); ++i) {
    const size_t kind = i < count && o.kinds.size() > 1 ? rng.below(o.kinds.size()) : 0;
    objects.push_back(o.loaded.asObject(*o.loaded.find(o.kinds[kind]), i));
  }
  w.setObjects(objects);
  const double surface = T_region.translation().z();
  const VecX zero = VecX::Zero(robot.dof());
  for (r.attempts = 1; r.attempts <= o.max_attempts; ++r.attempts) {
    w.reset(robot.home());
    for (int i = 0; i < w.numObjects(); ++i) w.parkObject(i);
    r.active.clear();
    std::vector<Vec3> centers;
    bool placed_all = true;
    const bool drop = o.drop && o.physics;
    for (int i = 0; i < count && placed_all; ++i) {
      bool placed = false;
      if (drop) {
        // Layers of three, 7 cm apart in height, each object clear of the others in its layer.
        const ObjectState proto = w.object(i);
        const double reach = proto.half_size.norm();
        for (int draw = 0; draw < 200 && !placed; ++draw) {
          Vec3 p = T_region * Vec3(rng.uniform(-half.x() + o.wall_margin, half.x() - o.wall_margin),
                                   rng.uniform(-half.y() + o.wall_margin, half.y() - o.wall_margin), 0.0);
          p.z() = surface + reach + 0.01 + 0.07 * (i / 3);
          const Mat3 R = uniformRotation(rng);
          bool clear = true;
          for (const Vec3& c : centers) clear = clear && (c - p).norm() >= 2 * reach + 0.002;
          if (!clear) continue;
          w.setObjectPose(i, makePose(p, R));
          centers.push_back(p);
          r.active.push_back(i);
          placed = true;
        }
        placed_all = placed;
        continue;
      }
      for (int draw = 0; draw < 200 && !placed; ++draw) {
        const Vec3 local(rng.uniform(-half.x() + o.wall_margin, half.x() - o.wall_margin),
                         rng.uniform(-half.y() + o.wall_margin, half.y() - o.wall_margin), 0.0);
        const double yaw = rng.uniform(-M_PI, M_PI);
        Vec3 p = T_region * local;
        bool clear = true;
        for (const Vec3& c : centers) clear = clear && (c - p).head<2>().norm() >= o.min_spacing;
        if (!clear) continue;
        const ObjectState me = w.object(i);
        if (o.min_gap > 0) {  // the outline keeps half the gap from the region's edges too
          const Mat3 Rl = T_region.linear().transpose() * rotZ(yaw);
          for (int e = 0; e < 2 && clear; ++e) {
            const double extent = me.shape == ObjectShape::kCylinder
                                      ? me.half_size.x()
                                      : std::abs(Rl(e, 0)) * me.half_size.x() + std::abs(Rl(e, 1)) * me.half_size.y();
            clear = std::abs(local[e]) + extent <= half[e] - o.min_gap / 2;
          }
        }
        if (o.min_gap > 0)
          for (size_t j = 0; j < r.active.size() && clear; ++j) {
            const ObjectState other = w.object(r.active[j]);
            clear = outlineGap(me.shape, me.half_size, makePose(p, Mat3(rotZ(yaw))), other.shape, other.half_size,
                               other.T_world_object) >= o.min_gap;
          }
        if (!clear) continue;
        const double hz = me.half_size.z();
        p.z() = surface + hz + (o.physics ? 0.001 : 0.0);
        w.setObjectPose(i, makePose(p, Mat3(rotZ(yaw))));
        centers.push_back(p);
        r.active.push_back(i);
        placed = true;
      }
      placed_all = placed;
    }
    if (!placed_all) {
      r.reason = "could not place " + std::to_string(count) + " objects " + std::to_string(o.min_spacing) + " m apart" +
                 (o.min_gap > 0 ? " with " + std::to_string(o.min_gap) + " m between them" : "");
      continue;
    }
    if (!o.physics) {
      r.ok = true;
      return r;
    }
    bool bad = false;
    for (int i : r.active)
      if (w.objectPenetration(i) > o.max_penetration) bad = true;
    if (bad) {
      r.reason = "objects interpenetrate at spawn";
      continue;
    }
    for (double t = 0; t < o.settle_time; t += w.controlPeriod()) {
      w.stepServo(robot.home(), zero, zero, robot.spec().gripper.travel, robot.spec().gripper.max_force);
      if (w.unstable()) break;
    }
    if (w.unstable()) {
      r.reason = "unstable while settling: " + w.instabilityReason();
      continue;
    }
    for (int i : r.active) {
      const ObjectState s = w.object(i);
      const Vec3 local = T_region.inverse() * s.T_world_object.translation();
      if (drop) {  // any orientation, inside the bin's walls, at rest
        if (w.objectPenetration(i) > o.max_penetration || std::abs(local.x()) > half.x() || std::abs(local.y()) > half.y() ||
            w.objectVelocity(i).norm() > 0.02) {
          bad = true;
          r.reason = "object " + s.name + " did not come to rest in the bin";
        }
        continue;
      }
      if (w.objectPenetration(i) > o.max_penetration || s.T_world_object.linear().col(2).z() < 0.95 ||
          std::abs(local.x()) > half.x() || std::abs(local.y()) > half.y() || w.objectVelocity(i).norm() > 0.02) {
        bad = true;
        char buf[160];
        std::snprintf(buf, sizeof buf, " (tilt %.1f deg, penetration %.1f mm, speed %.3f m/s)",
                      std::acos(std::clamp(s.T_world_object.linear()(2, 2), -1.0, 1.0)) * 180 / M_PI, 1000 * w.objectPenetration(i),
                      w.objectVelocity(i).norm());
        r.reason = "object " + s.name + " did not settle upright in the bin" + buf;
      }
    }
    if (!bad) {
      r.ok = true;
      return r;
    }
  }
  return r;
}

}  // namespace mm
