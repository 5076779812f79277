// Mixed bins: the outline gap between upright boxes and cylinders seen from above, and a spawn of
// 4-6 mixed objects that keeps that gap between them and half of it to the bin's edges.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/rng.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

Pose at(double x, double y, double yaw) { return makePose(Vec3(x, y, 0.05), Mat3(rotZ(yaw))); }

TEST(OutlineGap, BoxesAndCylindersSeenFromAbove) {
  const Vec3 cube(0.025, 0.025, 0.025), can(0.03, 0.03, 0.05);
  const auto box = ObjectShape::kBox;
  const auto cyl = ObjectShape::kCylinder;
  // Face to face, 5 cm between the faces.
  EXPECT_NEAR(outlineGap(box, cube, at(0, 0, 0), box, cube, at(0.1, 0, 0)), 0.05, 1e-12);
  // Turned 45 degrees: the corner comes 0.0104 m nearer (sqrt(2) * 2.5 cm - 2.5 cm).
  EXPECT_NEAR(outlineGap(box, cube, at(0, 0, 0), box, cube, at(0.1, 0, M_PI / 4)), 0.05 - (std::sqrt(2.0) - 1) * 0.025, 1e-12);
  // Diagonal neighbours: corner to corner.
  EXPECT_NEAR(outlineGap(box, cube, at(0, 0, 0), box, cube, at(0.1, 0.1, 0)), std::sqrt(2.0) * 0.05, 1e-12);
  // Crossed like a plus sign (no corner inside the other): overlapping.
  const Vec3 bar(0.06, 0.01, 0.01);
  EXPECT_EQ(outlineGap(box, bar, at(0, 0, 0), box, bar, at(0, 0, M_PI / 2)), 0.0);
  // Cylinders: along the line of centres; against a box: to its nearest face or corner.
  EXPECT_NEAR(outlineGap(cyl, can, at(0, 0, 0), cyl, can, at(0.1, 0, 1.0)), 0.04, 1e-12);
  EXPECT_NEAR(outlineGap(cyl, can, at(0, 0, 0), box, cube, at(0.1, 0, 0)), 0.045, 1e-12);
  EXPECT_NEAR(outlineGap(box, cube, at(0.1, 0.1, 0), cyl, can, at(0, 0, 0)), std::sqrt(2.0) * 0.075 - 0.03, 1e-12);
}

TEST(MixedSpawn, FourToSixMixedObjectsKeepTheirGapUpright) {
  const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  auto w = SimWorld::load("scenes/bin_large.xml", robot);
  const auto [T_bin, half] = w->site("bin_region");
  SpawnOptions o;
  o.kinds = {"cube_5cm", "cuboid_tall", "flat_box", "bottle", "can"};
  o.count_min = 4;
  o.count_max = 6;
  o.min_spacing = 0.05;
  o.min_gap = 0.06;
  o.wall_margin = 0.0;
  o.resolve("(test)");
  for (uint64_t trial = 0; trial < 4; ++trial) {
    Rng rng = Rng::stream(1, trial, Purpose::kScene);
    const SpawnResult r = spawnObjects(*w, robot, T_bin, half, rng, o);
    ASSERT_TRUE(r.ok) << r.reason;
    ASSERT_GE(r.active.size(), 4u);
    for (size_t a = 0; a < r.active.size(); ++a) {
      const ObjectState p = w->object(r.active[a]);
      EXPECT_GT(p.T_world_object.linear()(2, 2), 0.999) << p.name << " upright";
      EXPECT_NEAR(p.T_world_object.translation().z(), T_bin.translation().z() + p.half_size.z(), 0.002) << p.name << " resting";
      for (size_t b = a + 1; b < r.active.size(); ++b) {
        const ObjectState q = w->object(r.active[b]);
        // Settling moves them by a fraction of a millimetre at most.
        EXPECT_GT(outlineGap(p.shape, p.half_size, p.T_world_object, q.shape, q.half_size, q.T_world_object), 0.06 - 0.001)
            << p.name << " " << q.name;
      }
    }
  }
}

}  // namespace
}  // namespace mm
