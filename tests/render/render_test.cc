// Offscreen rendering (EGL; Mesa's llvmpipe on a CPU-only machine): rendered geometry agrees with
// the scene to < 1 px and < 1 mm, segmentation labels the objects, rendering leaves the world as it
// was, a video is an MP4 that ffprobe reads with the frames written, and a trial rendered again
// from its seed matches its line in trials.jsonl.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>

#include "../campaign/cli_helpers.h"
#include "core/error.h"
#include "render/image_io.h"
#include "render/renderer.h"
#include "test_renderer.h"
#include "sim/object_catalogue.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;
using json = nlohmann::json;
using testing_cli::readTrials;
using testing_cli::runMinimanip;
using testing_cli::TempDir;

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

using testing_render::renderer;

// Two cubes on the bin floor at known poses (one turned 30 degrees), the arm at home.
struct Scene {
  std::unique_ptr<SimWorld> world;
  std::vector<Pose> cubes;
  double half = 0;
  Scene() {
    const ObjectCatalogue cat = loadObjectCatalogue("scenes/objects.yaml");
    const ObjectKind cube = *cat.find("cube_5cm");
    half = cube.half_size.z();
    world = SimWorld::load("scenes/bin_table.xml", panda(), {cube, cube});
    world->reset(panda().home());
    const Pose T_bin = world->site("bin_region").first;
    for (int i = 0; i < 2; ++i) {
      Vec3 p = T_bin.translation() + Vec3(i == 0 ? -0.04 : 0.05, i == 0 ? 0.05 : -0.06, 0);
      p.z() = world->surfaceBelow(p + Vec3(0, 0, 0.2), -1) + half;
      cubes.push_back(makePose(p, Mat3(Eigen::AngleAxisd(i == 0 ? 0.0 : M_PI / 6, Vec3::UnitZ()))));
      world->setObjectPose(i, cubes.back());
    }
    world->updateKinematics();
  }
};

TEST(Render, DepthAndPixelsMatchTheSceneGeometry) {
  Scene s;
  const CameraModel cam = renderer().camera(*s.world, "overhead_camera", 640, 480, "(test)");
  const Frame f = renderer().render(*s.world, cam, kRgb | kDepth | kSegmentation);
  ASSERT_EQ(f.rgb.size(), 640u * 480u * 3u);
  ASSERT_EQ(f.depth.size(), 640u * 480u);
  ASSERT_EQ(f.segmentation.size(), 640u * 480u);
  auto at = [&](const auto& v, int u, int r) { return v[static_cast<size_t>(r) * 640 + static_cast<size_t>(u)]; };

  for (int i = 0; i < 2; ++i) {
    // The pixels whose ray meets the top face 2 mm or more inside its edges must show that face:
    // the cube's label and the plane's depth. Which pixels they are comes from the geometry alone.
    const Pose& T = s.cubes[static_cast<size_t>(i)];
    const Vec3 top = T * Vec3(0, 0, s.half);
    const Vec3 n_cam = cam.T_world_camera.linear().transpose() * Vec3::UnitZ();  // the plane's normal in the camera
    const Vec3 p_cam = cam.T_world_camera.inverse() * top;
    double su = 0, sv = 0, worst_depth = 0;
    long count = 0, wrong_label = 0;
    for (int r = 0; r < 480; ++r)
      for (int u = 0; u < 640; ++u) {
        const Vec3 ray((u - cam.cx) / cam.fx, (r - cam.cy) / cam.fy, 1.0);
        const double z_plane = n_cam.dot(p_cam) / n_cam.dot(ray);
        const Vec3 local = T.inverse() * (cam.T_world_camera * (z_plane * ray));
        if (std::abs(local.x()) > s.half - 0.002 || std::abs(local.y()) > s.half - 0.002) continue;
        wrong_label += at(f.segmentation, u, r) != kSegmentObject0 + i;
        worst_depth = std::max(worst_depth, std::abs(at(f.depth, u, r) - z_plane));
        su += u, sv += r, ++count;
      }
    ASSERT_GT(count, 200) << "cube " << i << " shows its top face";
    EXPECT_EQ(wrong_label, 0) << "cube " << i << ": pixels of its top face labelled otherwise";
    EXPECT_LT(worst_depth, 0.001) << "cube " << i << " at the right depth";
    // Those pixels' centroid is the face centre's projection (a 46 mm square's perspective shifts
    // its centroid by far less than 0.1 px here).
    const Vec3 c = cam.project(top);
    EXPECT_LT(std::hypot(su / count - c.x(), sv / count - c.y()), 1.0) << "cube " << i << " at the right pixel";
    // The face's labelled area: its projected area (side 0.05 m at depth z: (0.05 fx / z)^2 px), within 10%.
    long labelled = 0;
    for (uint8_t l : f.segmentation) labelled += l == kSegmentObject0 + i;
    const double expected = std::pow(2 * s.half * cam.fx / c.z(), 2);
    EXPECT_GT(labelled, 0.9 * expected) << "cube " << i;
    EXPECT_LT(labelled, 1.6 * expected) << "cube " << i << " (its sides show a little in perspective)";
    // The rendered face (its label, at the plane's depth, as drawn) has its centroid at the face
    // centre's projection: checks the pixel convention itself (a half-pixel shift shows here).
    double ru = 0, rv = 0;
    long rn = 0;
    for (int r = 0; r < 480; ++r)
      for (int u = 0; u < 640; ++u) {
        if (at(f.segmentation, u, r) != kSegmentObject0 + i) continue;
        const Vec3 ray((u - cam.cx) / cam.fx, (r - cam.cy) / cam.fy, 1.0);
        if (std::abs(at(f.depth, u, r) - n_cam.dot(p_cam) / n_cam.dot(ray)) > 0.0005) continue;
        ru += u, rv += r, ++rn;
      }
    ASSERT_GT(rn, 200);
    // Measured: 0.19 px (the axis-aligned cube: its edges fall on the pixel grid) and 0.05 px.
    EXPECT_LT(std::hypot(ru / rn - c.x(), rv / rn - c.y()), 0.3) << "cube " << i << ": the rendered face's centroid";
    // A pixel at its centre, unprojected with its depth, is the top face's centre.
    const int u = static_cast<int>(std::lround(c.x())), r = static_cast<int>(std::lround(c.y()));
    EXPECT_LT((cam.unproject(u, r, at(f.depth, u, r)) - top).norm(), 0.0015);
  }
  // Scene pixels unproject onto the surfaces below them (table, bins, floor) within 1 mm.
  int checked = 0;
  for (int r = 10; r < 480; r += 37)
    for (int u = 10; u < 640; u += 41) {
      if (at(f.segmentation, u, r) != kSegmentScene || at(f.depth, u, r) <= 0) continue;
      const Vec3 p = cam.unproject(u, r, at(f.depth, u, r));
      const double surface = s.world->surfaceBelow(p + Vec3(0, 0, 0.0005), -1);
      if (std::abs(p.z() - surface) > 0.005) continue;  // a wall's side seen at a grazing angle
      EXPECT_NEAR(p.z(), surface, 0.001) << "pixel " << u << "," << r;
      ++checked;
    }
  EXPECT_GT(checked, 100);
  // The robot is labelled (its base in view).
  long robot = 0;
  for (uint8_t l : f.segmentation) robot += l == kSegmentRobot;
  EXPECT_GT(robot, 1000);
}

// Near things are drawn: MuJoCo scales its clip planes by the model's extent, which objects
// parked far below the floor stretch to a hundred metres (near plane ~1 m: the arm vanished from
// the overhead camera and the wrist camera saw nothing). And the wrist camera looks along the
// fingers, into the bin.
TEST(Render, TheOverheadCameraShowsTheArmAndTheWristCameraTheBin) {
  Scene s;
  const Pose T_world_tcp = s.world->tcpPose();
  {
    const CameraModel cam = renderer().camera(*s.world, "overhead_camera", 640, 480, "(test)");
    const Frame f = renderer().render(*s.world, cam, kDepth | kSegmentation);
    long robot = 0;
    for (uint8_t l : f.segmentation) robot += l == kSegmentRobot;
    // Measured: 16,113 pixels (5.2%) at home; with the planes scaled by the parked objects' extent,
    // 4,808 (the base and the links' far sides only).
    EXPECT_GT(robot, 640 * 480 / 50) << "the arm shows from above";
    // Above the TCP (between the fingertips) the ray meets the arm: the robot's label, at a depth
    // in front of the TCP, within the hand and last link's length of it (0.35 m; measured 0.19 m:
    // link 7 over the wrist).
    const Vec3 c = cam.project(T_world_tcp.translation());
    const int u = static_cast<int>(std::lround(c.x())), r = static_cast<int>(std::lround(c.y()));
    ASSERT_TRUE(u >= 0 && u < 640 && r >= 0 && r < 480) << "the TCP is in view";
    const size_t i = static_cast<size_t>(r) * 640 + static_cast<size_t>(u);
    EXPECT_EQ(f.segmentation[i], kSegmentRobot);
    EXPECT_LT(f.depth[i], c.z());
    EXPECT_GT(f.depth[i], c.z() - 0.35);
  }
  {
    const CameraModel cam = renderer().camera(*s.world, "wrist_camera", 320, 240, "(test)");
    // It looks along the fingers (the TCP's z), down at home.
    EXPECT_GT(cam.T_world_camera.linear().col(2).dot(T_world_tcp.linear().col(2)), 0.99);
    const Frame f = renderer().render(*s.world, cam, kDepth | kSegmentation);
    // The bin region's centre (no cube there) is seen on the bin's floor, to a millimetre.
    const Pose T_bin = s.world->site("bin_region").first;
    Vec3 floor = T_bin.translation();
    floor.z() = s.world->surfaceBelow(floor + Vec3(0, 0, 0.2), -1);
    const Vec3 c = cam.project(floor);
    const int u = static_cast<int>(std::lround(c.x())), r = static_cast<int>(std::lround(c.y()));
    ASSERT_TRUE(c.z() > 0 && u >= 0 && u < 320 && r >= 0 && r < 240) << "the bin is in the wrist camera's view";
    const size_t i = static_cast<size_t>(r) * 320 + static_cast<size_t>(u);
    EXPECT_EQ(f.segmentation[i], kSegmentScene);
    EXPECT_LT((cam.unproject(u, r, f.depth[i]) - floor).norm(), 0.002) << "depth " << f.depth[i] << " m, the floor at " << c.z() << " m";
    // Both cubes show in it.
    long cube[2] = {0, 0}, empty = 0;
    for (size_t k = 0; k < f.segmentation.size(); ++k) {
      if (f.segmentation[k] == kSegmentObject0) ++cube[0];
      if (f.segmentation[k] == kSegmentObject0 + 1) ++cube[1];
      empty += f.depth[k] == 0;  // nothing hit: sky
    }
    EXPECT_GT(cube[0], 100);
    EXPECT_GT(cube[1], 100);
    EXPECT_LT(empty, static_cast<long>(f.depth.size()) / 10) << "the wrist camera looks at the cell, not at the sky";
  }
}

TEST(Render, RenderingLeavesTheWorldAsItWas) {
  Scene s;
  const VecX q = s.world->armPositions();
  const Pose T0 = s.world->object(1).T_world_object;
  const double t = s.world->time();
  const CameraModel cam = renderer().camera(*s.world, "overhead_camera", 320, 240, "(test)");
  const Frame a = renderer().render(*s.world, cam, kRgb | kDepth | kSegmentation);
  const Frame b = renderer().render(*s.world, cam, kRgb | kDepth | kSegmentation);
  EXPECT_EQ(a.rgb, b.rgb) << "the same world renders the same image";
  EXPECT_EQ(a.segmentation, b.segmentation);
  EXPECT_EQ(s.world->armPositions(), q);
  EXPECT_TRUE(s.world->object(1).T_world_object.isApprox(T0));
  EXPECT_EQ(s.world->time(), t);
}

TEST(Render, UnknownCameraIsBadInput) {
  Scene s;
  try {
    renderer().camera(*s.world, "nope", 64, 48, "exp.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("exp.yaml"));
    EXPECT_THAT(e.what(), HasSubstr("overhead_camera"));
  }
}

TEST(Render, DepthPngRoundTripsToATenthOfAMillimetre) {
  Scene s;
  TempDir tmp;
  const CameraModel cam = renderer().camera(*s.world, "overhead_camera", 160, 120, "(test)");
  const Frame f = renderer().render(*s.world, cam, kDepth);
  const std::string path = (tmp.path() / "d.png").string();
  writeDepthPng(path, f);
  int w = 0, h = 0;
  const std::vector<float> z = readDepthPng(path, &w, &h);
  ASSERT_EQ(w, 160);
  ASSERT_EQ(h, 120);
  for (size_t i = 0; i < z.size(); ++i) ASSERT_NEAR(z[i], f.depth[i], 0.5 * kDepthPngScale + 1e-6);
}

TEST(Render, VideoIsAnMp4FfprobeReads) {
  Scene s;
  TempDir tmp;
  const CameraModel cam = renderer().camera(*s.world, "overhead_camera", 320, 240, "(test)");
  const std::string path = (tmp.path() / "v.mp4").string();
  VideoWriter video(path, 320, 240, 25);
  for (int k = 0; k < 30; ++k) {
    VecX q = panda().home();
    q[0] += 0.02 * k;
    s.world->setArm(q);
    s.world->updateKinematics();
    video.add(renderer().render(*s.world, cam, kRgb));
  }
  EXPECT_EQ(video.close(), 30);
  FILE* p = popen(("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                   "stream=codec_name,width,height,nb_read_frames,avg_frame_rate -of csv=p=0 '" + path + "'").c_str(), "r");
  ASSERT_NE(p, nullptr);
  char buf[256] = "";
  const size_t n = fread(buf, 1, sizeof buf - 1, p);
  buf[n] = 0;
  EXPECT_EQ(pclose(p), 0);
  EXPECT_EQ(std::string(buf), "h264,320,240,25/1,30\n");
}

TEST(Render, ATrialRenderedAgainMatchesItsLineAndWritesItsImages) {
  TempDir tmp;
  const std::string out = (tmp.path() / "run").string();
  // The campaign renders trial 1's end in the workers; trial 2 is rendered afterwards from its seed.
  const auto run = runMinimanip("run experiments/quickstart.yaml --trials 3 --jobs 2 --out " + out +
                                " --set progress=none --set render.keyframes=close_gripper,end --set render.trials=1");
  ASSERT_EQ(run.code, 0) << run.out;
  EXPECT_TRUE(fs::exists(fs::path(out) / "renders/trial_000001/01_close_gripper.png"));
  EXPECT_TRUE(fs::exists(fs::path(out) / "renders/trial_000001/02_end.png"));
  EXPECT_FALSE(fs::exists(fs::path(out) / "renders/trial_000000"));
  const auto r = runMinimanip("render " + out + " --trial 2 --set render.keyframes=place --set render.video=false");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("Replay matches trial 2"));
  // A folder of its own: the campaign's renders/ are left as the campaign made them.
  const fs::path dir = fs::path(out) / "replays/trial_000002";
  EXPECT_FALSE(fs::exists(fs::path(out) / "renders/trial_000002"));
  const cv::Mat rgb = cv::imread((dir / "01_place.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(rgb.cols, 640);
  EXPECT_EQ(rgb.rows, 480);
  EXPECT_EQ(rgb.channels(), 3);
  const cv::Mat depth = cv::imread((dir / "01_place_depth.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(depth.type(), CV_16UC1);
  const cv::Mat seg = cv::imread((dir / "01_place_seg.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(seg.type(), CV_8UC1);
  EXPECT_FALSE(fs::exists(dir / "trial.mp4"));

  // A line that says otherwise is found out.
  std::vector<json> trials = readTrials(out);
  {
    std::ofstream o(fs::path(out) / "trials.jsonl");
    for (json& t : trials) {
      if (t["trial"] == 2) t["place_position_error"] = 0.5;
      o << t.dump() << "\n";
    }
  }
  const auto differs = runMinimanip("render " + out + " --trial 2 --set render.keyframes=end --set render.video=false");
  EXPECT_EQ(differs.code, 1) << differs.out;
  EXPECT_THAT(differs.out, HasSubstr("place_position_error: 0.5 recorded"));
  // The second replay's frames only: the first one's are gone, not mixed in.
  EXPECT_TRUE(fs::exists(dir / "01_end.png"));
  EXPECT_FALSE(fs::exists(dir / "01_place.png"));

  // Bad input: a trial the campaign did not run, a setting that is not a render setting.
  const auto missing = runMinimanip("render " + out + " --trial 7");
  EXPECT_EQ(missing.code, 2) << missing.out;
  EXPECT_THAT(missing.out, HasSubstr("no line for trial 7"));
  const auto bad = runMinimanip("render " + out + " --trial 2 --set seed=4");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_THAT(bad.out, HasSubstr("render.KEY=VALUE"));
  const auto fps = runMinimanip("run experiments/quickstart.yaml --trials 1 --out " + out + "x --set render.fps=30");
  EXPECT_EQ(fps.code, 2) << fps.out;
  EXPECT_THAT(fps.out, HasSubstr("render.fps"));
}

// The picture of what the robot made of its view (render.images: segments): at the first
// perception its segments in hues, and at the grasp the same view with the chosen grasp's fingers
// drawn over it, nothing else changed.
TEST(Render, TheSegmentsPictureShowsTheViewsSegmentsAndThenTheChosenGrasp) {
  TempDir tmp;
  const std::string out = (tmp.path() / "run").string();
  const auto run = runMinimanip("run experiments/clutter_pile.yaml --trials 1 --jobs 1 --out " + out +
                                " --set progress=none --set tree=experiments/trees/clutter_removal_cloud.xml --set perception.mode=camera"
                                " --set perception.camera_width=640 --set perception.camera_height=480 --set bt.time_budget=12"
                                " --set render.keyframes=perception,close_gripper --set render.images=segments --set render.width=320 --set render.height=240");
  ASSERT_EQ(run.code, 0) << run.out;
  const fs::path dir = fs::path(out) / "renders/trial_000000";
  const cv::Mat view = cv::imread((dir / "01_perception_segments.png").string(), cv::IMREAD_COLOR);
  const cv::Mat grasp = cv::imread((dir / "02_close_gripper_segments.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(view.empty());
  ASSERT_FALSE(grasp.empty());
  EXPECT_EQ(view.cols, 640);  // the perception camera's image, not the render's 320 x 240
  EXPECT_EQ(view.rows, 480);
  EXPECT_FALSE(fs::exists(dir / "01_perception.png"));  // only the images asked for
  int coloured = 0, changed = 0;
  cv::Rect where;  // of the pixels that changed
  for (int i = 0; i < view.rows * view.cols; ++i) {
    const cv::Vec3b a = view.at<cv::Vec3b>(i), b = grasp.at<cv::Vec3b>(i);
    coloured += std::max({a[0], a[1], a[2]}) - std::min({a[0], a[1], a[2]}) > 40;
    if (a == b) continue;
    const cv::Rect pixel(i % view.cols, i / view.cols, 1, 1);
    where = changed++ ? (where | pixel) : pixel;
  }
  EXPECT_GT(coloured, 300) << "segments in hues";  // 5 to 10 objects, some 800 px at this size
  EXPECT_GT(changed, 100) << "the fingers drawn";
  // Only the fingers changed: two pads at most a stroke apart, about 50 px at this size.
  EXPECT_LT(where.width, 100) << where;
  EXPECT_LT(where.height, 100) << where;
}

}  // namespace
}  // namespace mm
