// Camera perception in piles: ten same-coloured cubes dropped into the bin (touching, leaning,
// stacked), seen once from the overhead camera with the stereo noise, scored against the truth the
// way BOP scores: an object counts when its visible fraction (its pixels in the view over its
// pixels alone in the same view) is at least 0.5; it is found when a detection's pose is within
// BOP's MSSD of 10% of its diameter (up to the cube's symmetries; 8.7 mm for the 5 cm cube); a
// detection whose centre is more than 1 cm from every object is false. A visible object not found
// must lie under an obstacle made of the points no detection explains, or near a detection.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "core/rng.h"
#include "perception/camera_perception.h"
#include "render/renderer.h"
#include "../render/test_renderer.h"
#include "object_pixels.h"
#include "sim/object_catalogue.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

using testing_render::renderer;

struct PileScore {
  int objects = 0, visible = 0, found = 0, found_visible = 0, detections = 0, false_detections = 0;
  int missed = 0, missed_known = 0;  ///< visible objects (>= 0.5) not found; of those, the ones an obstacle or a detection covers
  void add(const PileScore& o) {
    objects += o.objects, visible += o.visible, found += o.found, found_visible += o.found_visible;
    detections += o.detections, false_detections += o.false_detections;
    missed += o.missed, missed_known += o.missed_known;
  }
};

// One pile: spawned from (seed, trial) as a campaign's bin-clearing trial spawns it, perceived once.
PileScore scorePile(SimWorld& w, uint64_t seed, uint64_t trial, bool verbose) {
  const auto [T_bin, half] = w.site("bin_region");
  SpawnOptions so;
  so.count_min = so.count_max = 10;
  so.drop = true;
  so.wall_margin = 0.06;
  so.settle_time = 2.0;
  Rng rng = Rng::stream(seed, trial, Purpose::kScene);
  const SpawnResult r = spawnObjects(w, panda(), T_bin, half, rng, so);
  EXPECT_TRUE(r.ok) << r.reason;
  w.updateKinematics();
  const CameraModel cam = renderer().camera(w, "overhead_camera", 1280, 960, "(test)");
  Frame frame = renderer().render(w, cam, kDepth | kSegmentation);
  std::vector<Pose> poses;
  for (int i : r.active) poses.push_back(w.object(i).T_world_object);
  const testing_render::ObjectPixels px = testing_render::objectPixels(w, cam, r.active, frame);
  Rng noise = Rng::stream(seed, trial, Purpose::kCamera);
  applyDepthNoise(frame, DepthNoise{}, noise);
  const Vec3 cube_half = w.object(r.active[0]).half_size;
  CameraPerceptionOptions co;
  co.T_world_crop = T_bin;
  co.crop_half = half;
  co.crop_height = 0.15;  // as a campaign sets it: three cubes stacked
  Rng prng = Rng::stream(seed, trial, Purpose::kPerception);
  const CameraPerceptionResult det = detectKnownObjects(frame, {{"cube_5cm", cube_half, 0.1}}, co, prng);
  PileScore s;
  s.objects = static_cast<int>(r.active.size());
  s.detections = static_cast<int>(det.detections.size());
  std::vector<char> used(det.detections.size(), 0);
  for (size_t k = 0; k < r.active.size(); ++k) {
    const double fraction = px.fraction(k);
    const bool vis = fraction >= 0.5;
    s.visible += vis;
    bool found = false;
    for (size_t d = 0; d < det.detections.size() && !found; ++d) {
      const PoseError e = poseError(det.detections[d].object.T_world_object, poses[k], cube_half);
      if (!used[d] && e.mssd < 0.1 * 2 * cube_half.norm()) used[d] = 1, found = true;
    }
    s.found += found;
    s.found_visible += found && vis;
    // Visible but not found: it must still be known to be there, as an obstacle the planner
    // avoids (its centre under one of the unexplained boxes, grown by 1 cm) or a detection near it
    // (one off by more than the MSSD bound).
    if (!found && vis) {
      ++s.missed;
      bool known = false;
      for (const Obstacle& ob : det.unexplained) {
        const Vec3 q = ob.T_world.inverse() * poses[k].translation();
        known = known || (std::abs(q.x()) < ob.size.x() + 0.01 && std::abs(q.y()) < ob.size.y() + 0.01);
      }
      for (const CameraDetection& d : det.detections)
        known = known || (d.object.T_world_object.translation() - poses[k].translation()).norm() < 0.03;
      s.missed_known += known;
      if (verbose && !known) {
        const Vec3 p = T_bin.inverse() * poses[k].translation();
        std::printf("  trial %llu: not known: object at (%.3f, %.3f, %.3f), visible %.2f\n", static_cast<unsigned long long>(trial), p.x(),
                    p.y(), p.z(), fraction);
      }
    }
    if (verbose && vis && !found) {
      const Vec3 p = T_bin.inverse() * poses[k].translation();
      double up = 0;
      for (int a = 0; a < 3; ++a) up = std::max(up, std::abs(poses[k].linear().col(a).z()));
      std::printf("  trial %llu: missed object at (%.3f, %.3f, %.3f) tilt %.1f deg, visible %.2f\n",
                  static_cast<unsigned long long>(trial), p.x(), p.y(), p.z(), std::acos(std::min(1.0, up)) * 180 / M_PI, fraction);
    }
  }
  for (size_t d = 0; d < det.detections.size(); ++d) {
    double nearest = 1;
    for (const Pose& P : poses) nearest = std::min(nearest, (P.translation() - det.detections[d].object.T_world_object.translation()).norm());
    s.false_detections += nearest > 0.01;
    if (verbose && !used[d]) {
      PoseError best{1, 1, 1};
      for (const Pose& P : poses) {
        const PoseError e = poseError(det.detections[d].object.T_world_object, P, cube_half);
        if (e.centre < best.centre) best = e;
      }
      const Vec3 p = T_bin.inverse() * det.detections[d].object.T_world_object.translation();
      std::printf("  trial %llu: unmatched detection at (%.3f, %.3f, %.3f), face %d px: nearest %.1f mm, %.1f deg\n",
                  static_cast<unsigned long long>(trial), p.x(), p.y(), p.z(), det.detections[d].face_pixels, 1e3 * best.centre,
                  best.rotation * 180 / M_PI);
    }
  }
  return s;
}

// The figure (MM_PILES=N prints it over N piles); the test asserts it on a few.
TEST(PilePerception, FindsTheVisibleCubesOfDroppedPiles) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  const char* env = std::getenv("MM_PILES");
  const int piles = env ? std::atoi(env) : 3;
  PileScore total;
  for (int t = 0; t < piles; ++t) total.add(scorePile(*w, 1, static_cast<uint64_t>(t), env != nullptr));
  std::printf("piles %d: objects %d, visible >= 0.5: %d, found %d (of the visible %d = %.1f%%), detections %d, false %d; "
              "visible and not found %d, of which under an obstacle or near a detection %d\n",
              piles, total.objects, total.visible, total.found, total.found_visible, 100.0 * total.found_visible / std::max(1, total.visible),
              total.detections, total.false_detections, total.missed, total.missed_known);
  // On seed 1's first three piles today: 28 of the 30 visible found, 2 false detections (ten
  // piles: 86 of 96, 3 false); the top-face fitter before found 29% of the visible.
  EXPECT_GE(total.found_visible, 0.85 * total.visible);
  EXPECT_LE(total.false_detections, std::max(1, total.detections / 10));
  EXPECT_EQ(total.missed_known, total.missed) << "an object perception missed must be avoided, not hit";
}

}  // namespace
}  // namespace mm
