// The camera registered against the cell's static boxes: a camera knocked off its mount (the
// renderer draws from the knocked pose, the frame still reports the mount's) is found where it
// really is, to a fraction of a millimetre and a hundredth of a degree, with and without the
// sensor's noise; a camera on its mount is left where it is; the quick check perception runs on
// every frame sees a knock and passes an unknocked frame.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "perception/camera_perception.h"
#include "perception/cell_registration.h"
#include "render/renderer.h"
#include "../render/test_renderer.h"
#include "sim/object_catalogue.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

using testing_render::renderer;

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

struct Cell {
  std::unique_ptr<SimWorld> world;
  CellRegistrationOptions options;
  Cell() {
    ObjectKind cube = *loadObjectCatalogue("scenes/objects.yaml").find("cube_5cm");
    world = SimWorld::load("scenes/bin_table.xml", panda(), {cube, cube});
    world->reset(panda().home());
    const auto [T_bin, half] = world->site("bin_region");
    // Two cubes in the bin, one against a wall: objects, not the cell.
    world->setObjectPose(0, makePose(T_bin * Vec3(0.0, 0.02, 0.025), rotZ(0.4)));
    world->setObjectPose(1, makePose(T_bin * Vec3(0.124, -0.05, 0.025), Mat3::Identity()));
    world->updateKinematics();
    options.T_world_bin = T_bin;
    options.bin_half = half;
  }
  // A frame of the overhead camera knocked by `knock`; the true pose in *truth.
  Frame frame(const Pose& knock, double noise_k, Pose* truth, int width = 640, int height = 480) {
    world->setCameraOffset("overhead_camera", knock);
    const CameraModel cam = renderer().camera(*world, "overhead_camera", width, height, "(test)");
    Frame f = renderer().render(*world, cam, kDepth);
    *truth = cam.T_world_camera * knock;
    EXPECT_TRUE(f.camera.T_world_camera.isApprox(cam.T_world_camera)) << "the frame reports the mount's pose";
    if (noise_k > 0) {
      DepthNoise noise;
      noise.k = noise_k;
      Rng rng(11);
      applyDepthNoise(f, noise, rng);
    }
    options.depth_sigma_k = noise_k;
    return f;
  }
};

double angleBetween(const Pose& a, const Pose& b) { return Eigen::AngleAxisd(a.linear() * b.linear().transpose()).angle(); }

TEST(CellRegistration, FindsAKnockedCamera) {
  Cell cell;
  const Pose knocks[] = {
      makePose(Vec3(0.003, -0.002, 0.001), Mat3(Eigen::AngleAxisd(1.5 * M_PI / 180, Vec3(1, 0.3, 0).normalized()))),
      makePose(Vec3(-0.004, 0.001, -0.003), Mat3(Eigen::AngleAxisd(2.0 * M_PI / 180, Vec3(0.1, 0.2, 1).normalized()))),  // mostly a turn about the optical axis
      makePose(Vec3(0.0, 0.0, 0.005), Mat3(Eigen::AngleAxisd(1.0 * M_PI / 180, Vec3(-0.5, 1, 0.5).normalized()))),
  };
  for (double k : {0.0, 0.0015}) {
    for (const Pose& knock : knocks) {
      Pose truth;
      const Frame f = cell.frame(knock, k, &truth);
      const CellRegistration r = registerCameraToCell(f, cell.world->staticObstacles(), cell.options);
      ASSERT_TRUE(r.ok) << r.reason;
      std::printf("knock %.2f deg %.1f mm, noise k %.4f: registered to %.2f mm, %.3f deg of the truth (%d points, %d iterations)\n",
                  angleBetween(knock, Pose::Identity()) * 180 / M_PI, 1e3 * knock.translation().norm(), k,
                  1e3 * (r.T_world_camera.translation() - truth.translation()).norm(), angleBetween(r.T_world_camera, truth) * 180 / M_PI,
                  r.points, r.iterations);
      EXPECT_LT((r.T_world_camera.translation() - truth.translation()).norm(), 0.001) << "noise " << k;
      EXPECT_LT(angleBetween(r.T_world_camera, truth), 0.06 * M_PI / 180) << "noise " << k;
      EXPECT_GT(r.rotation, 0.9 * M_PI / 180);
    }
  }
}

TEST(CellRegistration, LeavesACameraOnItsMountWhereItIs) {
  Cell cell;
  for (double k : {0.0, 0.0015}) {
    Pose truth;
    const Frame f = cell.frame(Pose::Identity(), k, &truth, 1280, 960);
    const CellRegistration r = registerCameraToCell(f, cell.world->staticObstacles(), cell.options);
    ASSERT_TRUE(r.ok) << r.reason;
    EXPECT_LT(r.translation, 0.0005) << "noise " << k;
    EXPECT_LT(r.rotation, 0.02 * M_PI / 180) << "noise " << k;
  }
}

TEST(CellRegistration, TheQuickCheckSeesAKnockAndPassesACameraOnItsMount) {
  Cell cell;
  for (const auto& [width, height] : {std::pair{640, 480}, std::pair{1280, 960}}) {
    Pose truth;
    Frame f = cell.frame(Pose::Identity(), 0.0015, &truth, width, height);
    CellRegistration r = registerCameraToCell(f, cell.world->staticObstacles(), checkOptions(cell.options));
    ASSERT_TRUE(r.ok) << r.reason;
    EXPECT_LT(r.bin_shift, 0.001) << width;  // perception's limit: 2 mm
    // Knocked by a degree about a nearly vertical axis (the least visible knock) and 2 mm.
    const Pose knock = makePose(Vec3(0.002, 0, 0), Mat3(Eigen::AngleAxisd(M_PI / 180, Vec3(0.1, 0, 1).normalized())));
    f = cell.frame(knock, 0.0015, &truth, width, height);
    r = registerCameraToCell(f, cell.world->staticObstacles(), checkOptions(cell.options));
    EXPECT_FALSE(r.blind);
    if (r.ok) {
      EXPECT_GT(r.bin_shift, 0.002) << width;
    }
  }
}

TEST(CellRegistration, AKnockLastsTheTrialOnly) {
  Cell cell;
  const Pose knock = makePose(Vec3(0.003, 0, 0), Mat3(Eigen::AngleAxisd(0.02, Vec3::UnitX())));
  ASSERT_TRUE(cell.world->setCameraOffset("overhead_camera", knock));
  EXPECT_FALSE(cell.world->setCameraOffset("no_such_camera", knock));
  const CameraModel cam = renderer().camera(*cell.world, "overhead_camera", 64, 48, "(test)");
  Frame knocked = renderer().render(*cell.world, cam, kDepth);
  cell.world->reset(panda().home());  // the next trial
  Frame next = renderer().render(*cell.world, cam, kDepth);
  cell.world->setCameraOffset("overhead_camera", Pose::Identity());
  Frame mounted = renderer().render(*cell.world, cam, kDepth);
  EXPECT_NE(knocked.depth, mounted.depth) << "the knock shows in the image";
  EXPECT_EQ(next.depth, mounted.depth) << "reset() puts the camera back on its mount";
}

TEST(CellRegistration, RefusesWhatItCannotFit) {
  Cell cell;
  Pose truth;
  Frame f = cell.frame(Pose::Identity(), 0.0, &truth);
  // A cell that is one endless flat box at the table's height: nothing pins x, y or the turn about z.
  Obstacle slab;
  slab.size = Vec3(10, 10, 0.1);
  slab.T_world = makePose(Vec3(0, 0, -0.1), Mat3::Identity());
  CellRegistrationOptions flat = cell.options;
  flat.bin_half = Vec3::Zero();
  CellRegistration r = registerCameraToCell(f, {slab}, flat);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.reason.find("unconstrained"), std::string::npos) << r.reason;
  // A black frame.
  std::fill(f.depth.begin(), f.depth.end(), 0.0f);
  r = registerCameraToCell(f, cell.world->staticObstacles(), cell.options);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.reason.find("sees too little"), std::string::npos) << r.reason;
}

}  // namespace
}  // namespace mm
