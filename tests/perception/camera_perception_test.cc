// Camera perception: boxes found in a rendered depth image by geometry alone (same-coloured
// objects; no colour, no simulator id) at the right pose; the depth noise model; pose errors that
// respect a box's symmetries.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "../campaign/cli_helpers.h"
#include "perception/camera_perception.h"
#include "render/renderer.h"
#include "../render/test_renderer.h"
#include "sim/hardware.h"
#include "sim/object_catalogue.h"
#include "sim/sim_world.h"
#include "../sanitized.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

using testing_render::renderer;

// Four grey cubes in the bin at known yaws, 1280 x 960 depth from the overhead camera.
struct Bin {
  std::unique_ptr<SimWorld> world;
  std::vector<Pose> truth;
  ObjectKind cube;
  CameraPerceptionOptions options;
  Frame frame;
  Bin() {
    cube = *loadObjectCatalogue("scenes/objects.yaml").find("cube_5cm");
    cube.rgba = {0.6, 0.6, 0.6, 1};
    cube.has_rgba = true;
    world = SimWorld::load("scenes/bin_table.xml", panda(), {cube, cube, cube, cube});
    world->reset(panda().home());
    const auto [T_bin, half] = world->site("bin_region");
    const Vec3 offsets[] = {{-0.06, 0.06, 0}, {0.06, 0.07, 0}, {-0.05, -0.07, 0}, {0.07, -0.06, 0}};
    const double yaws[] = {0.0, 0.3, -0.7, 1.2};
    for (int i = 0; i < 4; ++i) {
      Vec3 p = T_bin * offsets[i];
      p.z() = world->surfaceBelow(p + Vec3(0, 0, 0.2), -1) + cube.half_size.z();
      truth.push_back(makePose(p, rotZ(yaws[i])));
      world->setObjectPose(i, truth.back());
    }
    world->updateKinematics();
    options.T_world_crop = T_bin;
    options.crop_half = half;
    const CameraModel cam = renderer().camera(*world, "overhead_camera", 1280, 960, "(test)");
    frame = renderer().render(*world, cam, kDepth);
  }
  // The detection nearest each true cube, with its errors.
  std::vector<PoseError> errors(const CameraPerceptionResult& r) const {
    std::vector<PoseError> out;
    for (const Pose& T : truth) {
      const CameraDetection* best = nullptr;
      for (const CameraDetection& d : r.detections)
        if (!best || (d.object.T_world_object.translation() - T.translation()).norm() <
                         (best->object.T_world_object.translation() - T.translation()).norm())
          best = &d;
      out.push_back(best ? poseError(best->object.T_world_object, T, cube.half_size) : PoseError{1, 1, 1});
    }
    return out;
  }
};

TEST(CameraPerception, FindsSameColouredCubesFromDepthAlone) {
  Bin bin;
  Rng rng(7);
  const CameraPerceptionResult r = detectKnownObjects(bin.frame, {{"cube_5cm", bin.cube.half_size, 0.1}}, bin.options, rng);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.detections.size(), 4u);
  for (const PoseError& e : bin.errors(r)) {
    EXPECT_LT(e.centre, 0.001);
    EXPECT_LT(e.rotation, 0.5 * M_PI / 180);
  }
}

TEST(CameraPerception, WithStereoDepthNoiseThePosesStayWithinTwoMillimetresAndADegree) {
  Bin bin;
  Rng noise(11);
  applyDepthNoise(bin.frame, DepthNoise{}, noise);
  Rng rng(7);
  const CameraPerceptionResult r = detectKnownObjects(bin.frame, {{"cube_5cm", bin.cube.half_size, 0.1}}, bin.options, rng);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.detections.size(), 4u);
  double rotation = 0;
  for (const PoseError& e : bin.errors(r)) {
    EXPECT_LT(e.centre, 0.002);
    EXPECT_LT(e.rotation, 2 * M_PI / 180);
    EXPECT_LT(e.mssd, 0.003);
    rotation += e.rotation / 4;
  }
  EXPECT_LT(rotation, M_PI / 180) << "mean rotation error";
}

// The mixed shapes standing upright, all one grey: boxes by their top faces (a carton on end, a
// flat pack, a cube) and cylinders by their top discs (a bottle as wide as the cube, a can), each
// its own kind, with the stereo noise.
TEST(CameraPerception, FindsUprightCylindersByTheirDiscsBesideBoxes) {
  const ObjectCatalogue cat = loadObjectCatalogue("scenes/objects.yaml");
  std::vector<ObjectKind> kinds;
  std::vector<KnownShape> shapes;
  for (const char* name : {"cube_5cm", "cuboid_tall", "flat_box", "bottle", "can"}) {
    ObjectKind k = *cat.find(name);
    k.rgba = {0.6, 0.6, 0.6, 1};
    k.has_rgba = true;
    kinds.push_back(k);
    shapes.push_back({k.name, k.half_size, k.mass, k.shape});
  }
  auto world = SimWorld::load("scenes/bin_large.xml", panda(), kinds);
  world->reset(panda().home());
  const auto [T_bin, half] = world->site("bin_region");
  const Vec3 offsets[] = {{-0.1, 0.1, 0}, {0.1, 0.1, 0}, {-0.1, -0.1, 0}, {0.1, -0.1, 0}, {0.0, 0.0, 0}};
  const double yaws[] = {0.4, -0.3, 1.0, 0.0, 0.0};
  std::vector<Pose> truth;
  for (int i = 0; i < 5; ++i) {
    Vec3 p = T_bin * offsets[i];
    p.z() = world->surfaceBelow(p + Vec3(0, 0, 0.3), -1) + kinds[static_cast<size_t>(i)].half_size.z();
    truth.push_back(makePose(p, rotZ(yaws[i])));
    world->setObjectPose(i, truth.back());
  }
  world->updateKinematics();
  CameraPerceptionOptions options;
  options.T_world_crop = T_bin;
  options.crop_half = half;
  options.crop_height = 0.3;
  const CameraModel cam = renderer().camera(*world, "overhead_camera", 1280, 960, "(test)");
  Frame frame = renderer().render(*world, cam, kDepth);
  Rng noise(5);
  applyDepthNoise(frame, DepthNoise{}, noise);
  Rng rng(7);
  const CameraPerceptionResult r = detectKnownObjects(frame, shapes, options, rng);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.detections.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    const ObjectKind& k = kinds[static_cast<size_t>(i)];
    const CameraDetection* best = nullptr;
    for (const CameraDetection& d : r.detections)
      if (!best || (d.object.T_world_object.translation() - truth[i].translation()).norm() <
                       (best->object.T_world_object.translation() - truth[i].translation()).norm())
        best = &d;
    ASSERT_NE(best, nullptr);
    EXPECT_EQ(best->object.name, k.name);
    EXPECT_EQ(best->object.shape, k.shape) << k.name;
    EXPECT_LT((best->object.T_world_object.translation() - truth[i].translation()).norm(), 0.003) << k.name;
    EXPECT_LT(objectSymmetricAngle(best->object.T_world_object.linear(), truth[i].linear(), k.shape, k.half_size), 2 * M_PI / 180)
        << k.name;
  }
  EXPECT_TRUE(r.unexplained.empty()) << r.unexplained.size() << " patches unexplained, the first " << r.unexplained[0].name;
}

TEST(CameraPerception, DepthNoiseGrowsWithDepthSquaredAndDropsEdges) {
  Bin bin;
  Frame noisy = bin.frame;
  Rng rng(3);
  applyDepthNoise(noisy, DepthNoise{}, rng);
  double sum = 0, sum2 = 0, zsum = 0;
  long n = 0, dropped = 0;
  for (size_t i = 0; i < noisy.depth.size(); ++i) {
    if (bin.frame.depth[i] <= 0) continue;
    if (noisy.depth[i] == 0) {
      ++dropped;
      continue;
    }
    const double d = noisy.depth[i] - bin.frame.depth[i];
    const double z = bin.frame.depth[i];
    if (z < 1.2 || z > 1.3) continue;
    sum += d, sum2 += d * d, zsum += z, ++n;
  }
  ASSERT_GT(n, 10000);
  const double z = zsum / n, sigma = std::sqrt(sum2 / n - (sum / n) * (sum / n));
  EXPECT_NEAR(sigma, 0.0015 * z * z, 0.1 * 0.0015 * z * z) << "at " << z << " m";
  EXPECT_NEAR(sum / n, 0.0, 0.0001);
  EXPECT_GT(dropped, 500) << "edges (cube sides, bin walls) lose pixels";
  EXPECT_LT(dropped, static_cast<long>(noisy.depth.size() / 20));
}

// The noise as first written, pixel by pixel: each pixel's 3x3 neighbourhood read where it would
// drop. applyDepthNoise finds the edges by a min and max filter; the image must be the same, bit
// for bit, and the stream left at the same place.
void depthNoisePixelByPixel(Frame& f, const DepthNoise& noise, Rng& rng) {
  const int w = f.camera.width, h = f.camera.height;
  const std::vector<float> z0 = f.depth;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      double gauss, drop;
      rng.normalsAndUniforms(&gauss, &drop, 1);
      float& z = f.depth[static_cast<size_t>(v) * w + u];
      if (z <= 0) continue;
      if (drop < noise.edge_dropout) {
        float lo = z, hi = z;
        for (int dv = -1; dv <= 1; ++dv)
          for (int du = -1; du <= 1; ++du) {
            const float zz = z0[static_cast<size_t>(std::clamp(v + dv, 0, h - 1)) * w + std::clamp(u + du, 0, w - 1)];
            if (zz <= 0) continue;
            lo = std::min(lo, zz), hi = std::max(hi, zz);
          }
        if (hi - lo > noise.edge_jump) {
          z = 0;
          continue;
        }
      }
      z = static_cast<float>(z + gauss * noise.k * z * z);
    }
}

TEST(CameraPerception, DepthNoiseFindsTheEdgesAsEachPixelsNeighbourhoodReadsThem) {
  // Steps, holes, a NaN and an infinity, on odd sizes (a last row and column, a 1-pixel image).
  for (const auto& [w, h] : {std::pair{37, 23}, std::pair{1, 1}, std::pair{1, 9}, std::pair{8, 1}}) {
    Frame f;
    f.camera.width = w, f.camera.height = h;
    Rng shape(w * 100 + h);
    f.depth.resize(static_cast<size_t>(w) * h);
    for (float& z : f.depth) {
      const double r = shape.uniform();
      z = r < 0.1 ? 0.0f : r < 0.12 ? -1.0f : static_cast<float>(1.0 + (r < 0.5 ? 0.0 : 0.005 + 0.02 * shape.uniform()));
    }
    if (f.depth.size() > 10) f.depth[5] = std::nanf(""), f.depth[9] = std::numeric_limits<float>::infinity();
    for (const double dropout : {0.0, 0.5, 1.0}) {
      const DepthNoise noise{0.0015, 0.01, dropout};
      Frame a = f, b = f;
      Rng ra(7), rb(7);
      applyDepthNoise(a, noise, ra);
      depthNoisePixelByPixel(b, noise, rb);
      ASSERT_EQ(a.depth.size(), b.depth.size());
      for (size_t i = 0; i < a.depth.size(); ++i)
        EXPECT_TRUE(std::memcmp(&a.depth[i], &b.depth[i], sizeof(float)) == 0)
            << w << "x" << h << " dropout " << dropout << " pixel " << i << ": " << a.depth[i] << " against " << b.depth[i];
      EXPECT_EQ(ra.next(), rb.next()) << "the same numbers drawn";
    }
  }
}

TEST(CameraPerception, PoseErrorRespectsTheBoxSymmetries) {
  const Vec3 cube(0.025, 0.025, 0.025), slab(0.04, 0.025, 0.01);
  const Pose T = makePose(Vec3(0.5, 0.1, 0.03), rotZ(0.3));
  // A cube turned 90 degrees about any axis is the same cube.
  for (const Vec3 axis : {Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()}) {
    const Pose turned = T * makePose(Vec3::Zero(), Mat3(Eigen::AngleAxisd(M_PI / 2, axis)));
    const PoseError e = poseError(turned, T, cube);
    EXPECT_NEAR(e.rotation, 0, 1e-9);
    EXPECT_NEAR(e.mssd, 0, 1e-9);
  }
  // A slab turned 90 degrees about z is not: its long side moved.
  const PoseError e90 = poseError(T * makePose(Vec3::Zero(), rotZ(M_PI / 2)), T, slab);
  EXPECT_NEAR(e90.rotation, M_PI / 2, 1e-9);
  // ... but 180 degrees is.
  EXPECT_NEAR(poseError(T * makePose(Vec3::Zero(), rotZ(M_PI)), T, slab).rotation, 0, 1e-9);
  // A cylinder turned about its axis, or end over end, is the same cylinder; tilted, it is not.
  const Vec3 can(0.03, 0.03, 0.03);
  const PoseError turned = poseError(T * makePose(Vec3::Zero(), rotZ(0.7)), T, can, ObjectShape::kCylinder);
  EXPECT_NEAR(turned.rotation, 0, 1e-9);
  EXPECT_LT(turned.mssd, 0.03 * (M_PI / 90));  // the 2-degree sampling of the turns
  EXPECT_NEAR(poseError(T * makePose(Vec3::Zero(), rotX(M_PI)), T, can, ObjectShape::kCylinder).mssd, 0, 1e-9);
  EXPECT_NEAR(poseError(T * makePose(Vec3::Zero(), rotX(0.1)), T, can, ObjectShape::kCylinder).rotation, 0.1, 1e-9);
  // 10 degrees off and 2 mm aside: the angle, the distance, and MSSD = the farthest corner's shift.
  const Pose off = makePose(T.translation() + Vec3(0.002, 0, 0), T.linear() * rotZ(10 * M_PI / 180));
  const PoseError e = poseError(off, T, cube);
  EXPECT_NEAR(e.rotation, 10 * M_PI / 180, 1e-9);
  EXPECT_NEAR(e.centre, 0.002, 1e-12);
  EXPECT_GT(e.mssd, 2 * std::sin(5 * M_PI / 180) * cube.head<2>().norm());
}

TEST(CameraPerception, ACampaignInCameraModePicksWhatTheCameraSawAndRecordsItsErrors) {
  testing_cli::TempDir tmp;
  const std::string out = (tmp.path() / "cam").string();
  const auto run = testing_cli::runMinimanip("run experiments/camera.yaml --trials 4 --jobs 2 --set progress=none --out " + out);
  ASSERT_EQ(run.code, 0) << run.out;
  EXPECT_THAT(run.out, ::testing::HasSubstr("Camera Pose Error"));
  const auto trials = testing_cli::readTrials(out);
  ASSERT_EQ(trials.size(), 4u);
  for (const auto& t : trials) {
    EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
    ASSERT_EQ(t["detections"].size(), t["objects_in_bin"].get<size_t>()) << "every cube found once, nothing else";
    for (const auto& d : t["detections"]) {
      EXPECT_GE(d["object"].get<int>(), 0);
      EXPECT_LT(d["centre_error"].get<double>(), 0.002);
      EXPECT_LT(d["rotation_error"].get<double>(), 2 * M_PI / 180);
    }
    EXPECT_EQ(t["missed_detections"], 0);
  }
  // Ground truth on the same seeds records no detections.
  const auto gt = testing_cli::runMinimanip("run experiments/camera.yaml --trials 1 --jobs 1 --set progress=none "
                                            "--set perception.mode=ground_truth --out " + out + "_gt");
  ASSERT_EQ(gt.code, 0) << gt.out;
  EXPECT_TRUE(testing_cli::readTrials(out + "_gt")[0]["detections"].empty());
  // A camera the scene does not have is bad input, before any trial.
  const auto bad = testing_cli::runMinimanip("run experiments/camera.yaml --trials 1 --set perception.camera=nope --out " + out + "_bad");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_THAT(bad.out, ::testing::HasSubstr("perception.camera: the scene has no camera 'nope'"));
  EXPECT_THAT(bad.out, ::testing::HasSubstr("camera.yaml"));
}


// What the camera sees is what the robot knows: in camera mode the simulator's truth is closed to
// everything but a TruthScope (scoring, the world's own doings). A read outside one is a bug.
TEST(Truth, IsClosedOutsideATruthScopeWhenGuarded) {
  const ObjectCatalogue cat = loadObjectCatalogue("scenes/objects.yaml");
  const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  auto world = SimWorld::load("scenes/bin_table.xml", robot, {*cat.find("cube_5cm")});
  world->reset(robot.home());
  auto hw = makeMujocoHardware(*world, robot, {0});
  EXPECT_NO_THROW(hw->objects());  // unguarded: the ground-truth modes' sensor
  hw->guardTruth(true);
  EXPECT_THROW(hw->objects(), std::logic_error);
  EXPECT_THROW(hw->object(0), std::logic_error);
  EXPECT_THROW(hw->objectVelocity(0), std::logic_error);
  EXPECT_THROW(hw->tcpPose(), std::logic_error);
  EXPECT_THROW(hw->obstacles(), std::logic_error);
  EXPECT_THROW(hw->objectsTouched(), std::logic_error);
  try {
    hw->objects();
  } catch (const std::logic_error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("a decision must not rest on it"));
  }
  {
    const TruthScope scoring(*hw, "a test's scoring");
    EXPECT_EQ(hw->objects().size(), 1u);
    EXPECT_NO_THROW(hw->tcpPose());
  }
  EXPECT_THROW(hw->objects(), std::logic_error);  // closed again
  hw->guardTruth(false);
  EXPECT_NO_THROW(hw->objects());
}

// Camera-mode trials with the recovering tree and the faults that touch perception and the grasp:
// every trial runs to its end (a truth read by a decision would be an internal error, the trial a
// crash), and a false detection the camera made stays the robot's to find out.
TEST(Truth, CameraModeTrialsWithFaultsNeverReadTheTruthToDecide) {
  testing_cli::TempDir tmp;
  const std::string out = (tmp.path() / "cam").string();
  const auto run = testing_cli::runMinimanip(
      "run experiments/camera.yaml --trials 8 --jobs 2 --set progress=none --set tree=experiments/trees/recovering_pick_place.xml "
      "--set faults.perception_dropout=0.25 --set faults.false_detection=0.25 --set faults.object_moved=0.25 "
      "--set faults.grasp_slip=0.25 --set faults.gripper_no_close=0.25 --out " + out);
  ASSERT_EQ(run.code, 0) << run.out;
  for (const auto& t : testing_cli::readTrials(out)) {
    EXPECT_NE(t["failure_kind"], "crash") << t.dump();
    EXPECT_NE(t["tree_status"], "ERROR") << t.dump();
    EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
  }
}

TEST(Truth, CameraModeGraspsFromThePointsNeverReadTheTruthToDecide) {
  // Grasps from the camera's points, each tried on the detection its pads close on: the truth
  // stays closed (a read would be a crash of the trial).
  testing_cli::TempDir tmp;
  const std::string out = (tmp.path() / "cloud").string();
  // Four trials (two from 100 seeds under the sanitizers, where the detector's seconds become minutes).
  const int trials = testing_sanitized::sanitizedOr(2, 4);
  const std::string seeds = testing_sanitized::kSanitized ? " --set grasp.cloud_seeds=100" : "";
  const auto run = testing_cli::runMinimanip(
      "run experiments/camera.yaml --trials " + std::to_string(trials) + seeds + " --jobs 2 --set progress=none --set tree=experiments/trees/bin_picking_fixed.xml "
      "--set grasp.source=cloud --out " + out);
  ASSERT_EQ(run.code, 0) << run.out;
  int picks = 0;
  for (const auto& t : testing_cli::readTrials(out)) {
    EXPECT_NE(t["failure_kind"], "crash") << t.dump();
    EXPECT_NE(t["tree_status"], "ERROR") << t.dump();
    EXPECT_TRUE(t["oracle"].is_null()) << "camera mode from the depth: nothing given that a real cell has not";
    for (const auto& p : t["picks"]) {
      EXPECT_EQ(p["grasp_type"], "cloud");
      ++picks;
    }
  }
  EXPECT_GE(picks, trials);
}

TEST(Truth, UnknownObjectsAreSegmentedInCameraModeAndNeverReadTheTruthToDecide) {
  // Clutter rounds of generated objects in camera mode: no model, so each segment of the depth is a
  // perceived object (the columns under its points) and grasps come from the points. The truth
  // stays closed (a read would be a crash of the trial); it only scores.
  testing_cli::TempDir tmp;
  const std::string out = (tmp.path() / "unknown").string();
  // Two rounds (one, and at most a minute of simulated time, under the sanitizers, where the
  // detector's seconds become minutes).
  const int trials = testing_sanitized::sanitizedOr(1, 2);
  const std::string args = "run experiments/clutter_pile.yaml --trials " + std::to_string(trials) +
                           (testing_sanitized::kSanitized ? " --set grasp.cloud_seeds=100 --set bt.time_budget=60" : "") +
                           " --set progress=none --set perception.mode=camera --set tree=experiments/trees/clutter_removal_cloud.xml";
  const auto run = testing_cli::runMinimanip(args + " --jobs 2 --out " + out);
  ASSERT_EQ(run.code, 0) << run.out;
  int matched = 0, in_tray = 0;
  const std::vector<testing_cli::json> two = testing_cli::readTrials(out);
  ASSERT_EQ(two.size(), static_cast<size_t>(trials));
  for (const auto& t : two) {
    EXPECT_NE(t["failure_kind"], "crash") << t.dump();
    EXPECT_NE(t["tree_status"], "ERROR") << t.dump();
    EXPECT_FALSE(t["detections"].empty());
    for (const auto& d : t["detections"])
      if (d["object"].get<int>() >= 0) {
        ++matched;
        EXPECT_EQ(d["rotation_error"], -1) << "a segment has no orientation of its object's";
      }
    for (const auto& a : t["grasp_attempts"]) in_tray += a["result"] == "in_tray";
    // Placed with no target orientation: none is measured, and none enters the summary.
    EXPECT_EQ(t["place_orientation_error"], -1);
    // With no model the object is judged in its own slot of the place grid (half the 9.5 cm pitch
    // each way), not to the known objects' 2 cm: what stops a placed one is only leaving its slot
    // or still moving.
    for (const auto& p : t["picks"])
      if (p["at_target"].get<bool>()) {
        EXPECT_EQ(p["orientation_error"], -1);
        const auto& offset = p["offset"];
        const bool in_slot = std::max(std::abs(offset[0].get<double>()), std::abs(offset[1].get<double>())) <= 0.0475;
        if (p["placed"].get<bool>()) {
          EXPECT_TRUE(in_slot) << p.dump();
        } else if (!p["reason"].get<std::string>().empty()) {  // (empty: the evaluation itself failed)
          EXPECT_TRUE(!in_slot || p["reason"].get<std::string>().find("still moving") != std::string::npos) << p.dump();
        }
      }
  }
  EXPECT_GT(matched, 0);
  EXPECT_GE(in_tray, 1);
  const testing_cli::json summary = testing_cli::json::parse(std::ifstream(out + "/summary.json"));
  EXPECT_GE(summary["place_orientation_error_deg"]["max"].get<double>(), 0);
  if (testing_sanitized::kSanitized) return;
  // One worker, the same outcomes.
  const auto one = testing_cli::runMinimanip(args + " --jobs 1 --out " + out + "_1");
  ASSERT_EQ(one.code, 0) << one.out;
  const std::vector<testing_cli::json> single = testing_cli::readTrials(out + "_1");
  ASSERT_EQ(single.size(), two.size());
  for (size_t i = 0; i < two.size(); ++i) EXPECT_EQ(testing_cli::outcomeFields(single[i]), testing_cli::outcomeFields(two[i]));
}

}  // namespace
}  // namespace mm
