// Known objects' 6D poses (perception/model_pose.h) in piles of the catalogue's mesh solids,
// dropped and settled, seen once from the overhead camera with the stereo noise, scored after BOP:
// an object counts when its visible fraction is at least 0.5; its pose is right when the model
// found is its own and the pose's MSSD (over the model's symmetries) is under 10% of its diameter.
// Each object is posed from its segment: the renderer's labels' (the oracle, which measures the
// pose estimation alone) or the depth's (segmentDepth, the whole chain).
// MM_PILES=N prints the figures over N piles (MM_WIDTH=640 at 640 x 480; by default 1280 x 960, the camera perception's); the tests assert on a few.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <tuple>

#include "core/rng.h"
#include "perception/camera_perception.h"
#include "perception/model_pose.h"
#include "perception/segmentation.h"
#include "render/renderer.h"
#include "../render/test_renderer.h"
#include "object_pixels.h"
#include "../sanitized.h"
#include "../campaign/cli_helpers.h"
#include "robot/robot_model.h"
#include "robot/solid_mesh.h"
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

const std::vector<std::string> kKinds{"hex_prism", "wedge", "chamfered_block", "step_block", "frustum"};

Mat3 turn(const Vec3& axis, double degrees) { return Eigen::AngleAxisd(degrees * M_PI / 180, axis.normalized()).toRotationMatrix(); }

// The kinds' models as the catalogue gives them: their visual meshes and declared symmetries.
std::vector<std::shared_ptr<const ObjectModel>> models(const ObjectCatalogue& cat) {
  std::vector<std::shared_ptr<const ObjectModel>> out;
  for (const std::string& name : kKinds) {
    const ObjectKind* k = cat.find(name);
    out.push_back(std::make_shared<ObjectModel>(ObjectModel::fromMesh(name, k->solid->visual_vertices, k->solid->visual_faces, k->symmetries)));
  }
  return out;
}

// Which model object i of the world is: the one whose vertices its drawn surface has.
int modelOf(const SimWorld& w, int i, const std::vector<std::shared_ptr<const ObjectModel>>& ms) {
  const TriangleMesh s = w.objectSurface(i);
  for (size_t k = 0; k < ms.size(); ++k) {
    bool all = true;
    for (const Vec3& v : s.vertices) {
      double best = INFINITY;
      for (const Vec3& x : ms[k]->vertices) best = std::min(best, (v - x).norm());
      all = all && best < 2e-4;
    }
    if (all) return static_cast<int>(k);
  }
  return -1;
}

// The catalogue's declared symmetries, their groups checked against the meshes, and BOP's errors.
TEST(ModelPose, SymmetriesAndErrorsOfAHexagonalBar) {
  SpawnOptions so;
  so.kinds = kKinds;
  so.resolve("(test)");
  const auto ms = models(so.loaded);
  const ObjectModel& hex = *ms[0];
  EXPECT_EQ(hex.symmetries.size(), 12u);  // D6: six turns about its axis, each also end over end
  for (const Mat3& S : hex.symmetries) EXPECT_LT(symmetryResidual(hex.vertices, S), 1e-6);
  EXPECT_GT(symmetryResidual(hex.vertices, turn(Vec3::UnitZ(), 30)), 0.005);  // a half step: not a symmetry
  EXPECT_EQ(ms[2]->symmetries.size(), 2u);  // the chamfered block: a half turn about its height
  EXPECT_EQ(ms[4]->symmetries.size(), 4u);  // the frustum: quarter turns
  EXPECT_EQ(ms[1]->symmetries.size(), 1u);  // the wedge: none
  EXPECT_NEAR(hex.diameter, std::hypot(0.052, 0.05), 1e-4);  // corner to far corner
  const Pose truth = makePose(Vec3(0.5, 0.1, 0.3), Mat3(turn(Vec3(1, 2, 3), 40)));
  EXPECT_NEAR(mssd(hex, truth * makePose(Vec3::Zero(), Mat3(turn(Vec3::UnitZ(), 120))), truth), 0, 1e-9);
  EXPECT_NEAR(mssd(hex, truth * makePose(Vec3::Zero(), Mat3(turn(Vec3::UnitX(), 180))), truth), 0, 1e-9);
  EXPECT_NEAR(mssd(hex, truth * makePose(Vec3(0.003, 0, 0), Mat3::Identity()), truth), 0.003, 1e-9);
  // MSPD: a 3 mm shift across the view of a camera 0.5 m away with fx 500 px is 3 px; a symmetric twin, 0.
  CameraModel cam;
  cam.width = 640, cam.height = 480, cam.fx = cam.fy = 500, cam.cx = 319.5, cam.cy = 239.5;
  const Pose ahead = makePose(Vec3(0, 0, 0.5), Mat3(turn(Vec3(1, 2, 3), 40)));
  EXPECT_NEAR(mspd(hex, makePose(Vec3(0.003, 0, 0.5), ahead.linear()), ahead, cam), 3.0, 0.35);
  EXPECT_NEAR(mspd(hex, ahead * makePose(Vec3::Zero(), Mat3(turn(Vec3::UnitZ(), 60))), ahead, cam), 0, 1e-6);
  // The wedge has no symmetry: turned end over end, its far corners move by its length and more.
  EXPECT_GT(mssd(*ms[1], truth * makePose(Vec3::Zero(), Mat3(turn(Vec3::UnitX(), 180))), truth), 0.04);
}

// BOP's VSD of the hexagonal bar seen alone (the view's depth is its own drawing at the truth,
// nothing behind it): zero at the truth and at a symmetric twin, one where the poses do not
// overlap, and between, by tau, for a pose 1 cm too far (all its surface 0.14 d off).
TEST(ModelPose, VsdIsBopsVisibleSurfaceDiscrepancy) {
  SpawnOptions so;
  so.kinds = kKinds;
  so.resolve("(test)");
  const auto ms = models(so.loaded);
  const ObjectModel& hex = *ms[0];
  CameraModel cam;
  cam.width = 320, cam.height = 240, cam.fx = cam.fy = 400, cam.cx = 159.5, cam.cy = 119.5;
  const Pose truth = makePose(Vec3(0.01, -0.005, 0.5), Mat3(turn(Vec3(1, 2, 3), 40)));
  const ModelDrawing seen = drawModel(hex, truth, cam, 0, 0, cam.width, cam.height);
  const std::vector<double> taus{0.05, 0.1, 0.2, 0.5};
  for (double e : vsd(hex, truth, truth, cam, seen.depth, 0.015, taus)) EXPECT_EQ(e, 0);
  for (double e : vsd(hex, truth * makePose(Vec3::Zero(), Mat3(turn(Vec3::UnitZ(), 60))), truth, cam, seen.depth, 0.015, taus))
    EXPECT_LT(e, 0.03);  // the twin's drawing differs from the truth's by rasterised edges only
  for (double e : vsd(hex, makePose(truth.translation() + Vec3(0.1, 0, 0), truth.linear()), truth, cam, seen.depth, 0.015, taus))
    EXPECT_EQ(e, 1);
  const std::vector<double> far =
      vsd(hex, makePose(truth.translation() + Vec3(0, 0, 0.01), truth.linear()), truth, cam, seen.depth, 0.015, taus);
  EXPECT_GT(far[0], 0.95);  // 1 cm is 0.14 d: past tau 0.05 d and 0.1 d everywhere ...
  EXPECT_GT(far[1], 0.95);
  EXPECT_LT(far[2], 0.1);   // ... within 0.2 d but where the farther silhouette is smaller
  EXPECT_LT(far[3], 0.1);
  // Hidden behind a wall 10 cm nearer the camera, nothing of either is visible: an error of one.
  std::vector<float> wall(seen.depth.size(), 0.40f);
  for (double e : vsd(hex, truth, truth, cam, wall, 0.015, taus)) EXPECT_EQ(e, 1);
}

struct Score {
  int visible = 0, right = 0, posed = 0, wrong_model = 0, unmatched = 0;
  // As the campaigns score a view (task/perceive.cc): each object at least half visible matched to
  // a pose of its own model, the least MSSD first; right under 0.1 d. Every segment posed alone,
  // and the view posed whole (estimateView: a pose's pixels are its own, its segment's rest posed again).
  int right_per_segment = 0, right_view = 0;
  double seconds = 0;
  int estimates = 0;
  std::vector<double> errors;  // MSSD / diameter of each visible object posed with its own model
};

void scorePile(SimWorld& w, const ModelPoseEstimator& est, uint64_t trial, int width, int height, bool labels, bool verbose, Score& score,
               NoiseSampler sampler) {
  const auto [T_bin, half] = w.site("bin_region");
  SpawnOptions so;
  so.kinds = kKinds;
  so.resolve("(test)");
  so.count_min = 5, so.count_max = 10;
  so.drop = true;
  so.wall_margin = 0.07;
  so.settle_time = 2.0;
  Rng rng = Rng::stream(1, trial, Purpose::kScene);
  const SpawnResult r = spawnObjects(w, panda(), T_bin, half, rng, so);
  ASSERT_TRUE(r.ok) << r.reason;
  w.updateKinematics();
  const CameraModel cam = renderer().camera(w, "overhead_camera", width, height, "(test)");
  Frame frame = renderer().render(w, cam, kDepth | kSegmentation);
  const size_t n = r.active.size();
  const testing_render::ObjectPixels px = testing_render::objectPixels(w, cam, r.active, frame);
  Rng noise = Rng::stream(1, trial, Purpose::kCamera);
  DepthNoise depth_noise;
  depth_noise.sampler = sampler;
  if (!std::getenv("MM_NOISE_FREE")) applyDepthNoise(frame, depth_noise, noise);
  SegmentationOptions o;
  o.T_world_region = T_bin;
  o.region_half = half;
  o.region_height = 0.15;
  o.sanity_join = 0;  // LCCP's own segments, as camera mode gives them to the models (segmentationOptions)
  const Segmentation seg = labels ? segmentLabels(frame, o) : segmentDepth(frame, o);
  {
    std::vector<ModelPose> alone;
    for (const Segment& s : seg.segments) alone.push_back(est.estimate(frame, s));
    const ViewPoses view = est.estimateView(frame, seg.segments, o);
    for (int pass = 0; pass < 2; ++pass) {
      const std::vector<ModelPose>& poses = pass == 0 ? alone : view.poses;
      std::vector<std::tuple<double, size_t, size_t>> pairs;  // MSSD / d, object, pose
      for (size_t k = 0; k < r.active.size(); ++k) {
        if (px.fraction(k) < 0.5) continue;
        const int m = modelOf(w, r.active[k], est.models());
        const ObjectModel& model = *est.models()[static_cast<size_t>(m)];
        for (size_t j = 0; j < poses.size(); ++j)
          if (poses[j].ok && poses[j].model == m)
            pairs.emplace_back(mssd(model, poses[j].T_world_object, w.object(r.active[k]).T_world_object) / model.diameter, k, j);
      }
      std::sort(pairs.begin(), pairs.end());
      std::vector<char> object_used(r.active.size(), 0), pose_used(poses.size(), 0);
      std::vector<double> error(r.active.size(), INFINITY);
      for (const auto& [e, k, j] : pairs) {
        if (object_used[k] || pose_used[j]) continue;
        object_used[k] = pose_used[j] = 1;
        error[k] = e;
        (pass == 0 ? score.right_per_segment : score.right_view) += e < 0.1;
      }
      for (size_t k = 0; k < r.active.size() && verbose && pass == 1; ++k)
        if (px.fraction(k) >= 0.5 && !(error[k] < 0.1))
          std::printf("  pile %llu, the view: %s (visible %.2f) %s, MSSD %.3f d\n", static_cast<unsigned long long>(trial),
                      est.models()[static_cast<size_t>(modelOf(w, r.active[k], est.models()))]->name.c_str(), px.fraction(k),
                      std::isfinite(error[k]) ? "posed wrongly" : "no pose of its model", error[k]);
    }
    if (verbose)
      std::printf("  pile %llu: %zu segments, %d estimates, %zu poses, %zu unknown, %zu small\n", static_cast<unsigned long long>(trial),
                  seg.segments.size(), view.estimates, view.poses.size(), view.unknown.size(), view.small.size());
  }
  for (size_t k = 0; k < n; ++k) {
    if (px.fraction(k) < 0.5) continue;
    ++score.visible;
    const int i = r.active[k];
    const int m = modelOf(w, i, est.models());
    ASSERT_GE(m, 0) << "object " << i << " is none of the models";
    // Its segment: the one whose pixels overlap its visible mask at IoU >= 0.5.
    const Segment* mine = nullptr;
    for (const Segment& s : seg.segments) {
      int inter = 0;
      for (int p : s.pixels) inter += frame.segmentation[static_cast<size_t>(p)] == kSegmentObject0 + i;
      if (inter >= 0.5 * (static_cast<double>(s.pixels.size()) + px.visible[k] - inter)) mine = &s;
    }
    if (!mine) {
      ++score.unmatched;
      continue;
    }
    // The model drawn at the truth (the verification's z-buffer) agrees with the renderer's depth
    // over an object seen whole and its own segment.
    if (labels && px.fraction(k) > 0.95) {
      EXPECT_GE(est.verify(frame, *mine, m, w.object(i).T_world_object).score, 0.95) << est.models()[static_cast<size_t>(m)]->name;
    }
    const ModelPose p = est.estimate(frame, *mine);
    score.seconds += p.seconds, ++score.estimates;
    const Pose truth = w.object(i).T_world_object;
    const ObjectModel& model = *est.models()[static_cast<size_t>(m)];
    score.posed += p.ok;
    if (p.ok && p.model != m) ++score.wrong_model;
    const double e = p.ok && p.model == m ? mssd(model, p.T_world_object, truth) / model.diameter : INFINITY;
    if (std::isfinite(e)) score.errors.push_back(e);
    score.right += e < 0.1;
    if (verbose && !(e < 0.1)) {
      const ModelPose at_truth = est.verify(frame, *mine, m, truth);
      std::printf("  pile %llu: %s (visible %.2f) %s: score %.2f (%d/%d), MSSD %.3f d; at the truth: score %.2f\n",
                  static_cast<unsigned long long>(trial), model.name.c_str(), px.fraction(k),
                  !p.ok ? "not posed" : p.model != m ? "posed as another model" : "posed wrongly", p.score, p.agree, p.contradict,
                  e, at_truth.score);
    }
  }
}

Score scorePiles(int piles, int width, bool labels, bool verbose, const ModelPoseOptions& po = {}, int first = 0,
                 NoiseSampler sampler = NoiseSampler::kZiggurat) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  SpawnOptions so;
  so.kinds = kKinds;
  so.resolve("(test)");
  const auto t0 = std::chrono::steady_clock::now();
  const ModelPoseEstimator est(models(so.loaded), po);
  std::printf("trained in %.2f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  Score s;
  for (int t = first; t < first + piles; ++t) scorePile(*w, est, static_cast<uint64_t>(t), width, width * 3 / 4, labels, verbose, s, sampler);
  std::printf("%s segments, %d piles at %dx%d, seed 1: %d objects visible >= 0.5, %d with a segment, %d posed, %d right "
              "(MSSD < 0.1 d: %.1f%%), %d as another model; %.1f ms a segment\n",
              labels ? "the labels'" : "the depth's", piles, width, width * 3 / 4, s.visible, s.visible - s.unmatched, s.posed, s.right,
              100.0 * s.right / std::max(1, s.visible), s.wrong_model, 1e3 * s.seconds / std::max(1, s.estimates));
  std::printf("as the campaigns score a view: every segment posed alone %d right (%.1f%%), the view posed whole %d right (%.1f%%)\n",
              s.right_per_segment, 100.0 * s.right_per_segment / std::max(1, s.visible), s.right_view,
              100.0 * s.right_view / std::max(1, s.visible));
  return s;
}

// MM_PILES piles (default: 3, 1 sanitized) from pile MM_FIRST (default 0) at MM_WIDTH (default
// 1280) x 3/4 of it; MM_NO_TURNS leaves out the winner's turns (ModelPoseOptions::turns),
// MM_NO_FACES the faces laid on a segment's largest plane (plane_faces).
Score scoreFromEnvironment(bool labels) {
  const char* env = std::getenv("MM_PILES");
  const char* wide = std::getenv("MM_WIDTH");
  ModelPoseOptions po;
  po.turns = std::getenv("MM_NO_TURNS") == nullptr;
  po.plane_faces = std::getenv("MM_NO_FACES") == nullptr;
  const char* first = std::getenv("MM_FIRST");
  return scorePiles(env ? std::atoi(env) : testing_sanitized::sanitizedOr(1, 3), wide ? std::atoi(wide) : 1280, labels, env != nullptr, po,
                    first ? std::atoi(first) : 0);
}

// Seed 1's first three piles today: all 24 visible objects posed right from the labels' segments,
// 21 from the depth's, each segment alone, and 23 with the view posed whole (20 piles:
// docs/perception.md, Known objects' poses).
TEST(ModelPose, PosesTheKnownObjectsOfDroppedPilesFromTheLabelsSegments) {
  const Score s = scoreFromEnvironment(true);
  ASSERT_GT(s.visible, 0);
  EXPECT_GE(s.right, 0.9 * s.visible);
}

TEST(ModelPose, PosesTheKnownObjectsOfDroppedPilesFromTheDepthsSegments) {
  const Score s = scoreFromEnvironment(false);
  ASSERT_GT(s.visible, 0);
  EXPECT_GE(s.right, 0.75 * s.visible);
  EXPECT_GE(s.right_view, 0.9 * s.visible);
}

// The cases below were found in views whose noise Box-Muller drew (before 2026-12-06): they are
// scored with that noise, the views as they were found.
constexpr NoiseSampler kAsFound = NoiseSampler::kBoxMuller;

// Piles 18 and 19 of seed 1 each hold a chamfered block lying on its side: its votes put it turned
// over (the chamfer at the wrong end; its true pose verifies at 1.00, the turned one at 0.95-0.97).
// The best pose's half turns, refined and verified, find it (docs/perception.md, step 3).
TEST(ModelPose, AChamferedBlockOnItsSideIsNotPosedTurnedOver) {
  ModelPoseOptions off;
  off.turns = false;
  const Score without = scorePiles(2, 1280, true, false, off, 18, kAsFound);
  const Score with = scorePiles(2, 1280, true, false, {}, 18, kAsFound);
  ASSERT_EQ(with.visible, without.visible);
  EXPECT_GE(with.right, without.right + 2);
}

// Piles 6 and 7 of seed 1 each hold a step block lying on its base, which the depth's segmentation
// splits at its concave step: each half a 30 x 40 mm top and a little of a side. A face's point
// pairs locate nothing on it, and each half was posed as another model (its true pose verifies at
// 1.00). The model faces laid on a segment's largest plane find it (docs/perception.md, step 1).
TEST(ModelPose, AStepBlockSplitAtItsStepIsPosedByItsFaces) {
  ModelPoseOptions off;
  off.plane_faces = false;
  const Score without = scorePiles(2, 1280, false, false, off, 6, kAsFound);
  const Score with = scorePiles(2, 1280, false, false, {}, 6, kAsFound);
  ASSERT_EQ(with.visible, without.visible);
  EXPECT_GE(with.right_view, without.right_view + 2);
}

}  // namespace
}  // namespace mm
namespace mm {
namespace {

using testing_cli::runMinimanip;
using testing_cli::TempDir;

// A round of experiments/known_objects.yaml: camera mode (the truth guarded: a read of it by a
// decision throws), each segment posed by the five meshes' models; the detections posed by their
// own model record BOP's MSSD over the declared symmetries, and the round places objects.
TEST(ModelPose, ACameraModeRoundPosesTheKnownObjectsByTheirModels) {
  TempDir d;
  const testing_cli::RunResult r = runMinimanip("run experiments/known_objects.yaml --trials 1 --set progress=none "
                                                "--set objects.count_min=5 --set objects.count_max=5 --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = testing_cli::readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 1u);
  const auto& t = trials[0];
  int posed = 0, close = 0;
  for (const auto& det : t["detections"]) {
    const double e = det["mssd"].get<double>();
    if (e < 0) continue;
    ++posed;
    close += e < 0.1 * 0.06;  // a tenth of the smallest diameter of the five (the frustum's, 6.2 cm)
  }
  EXPECT_GE(posed, 3) << t["detections"].dump();
  EXPECT_GE(close, posed * 3 / 4) << t["detections"].dump();
  EXPECT_GE(t["objects_placed"].get<int>(), 1) << t.dump();
  // Each view's pose estimation scored as BOP's targets, and the recall in the summary.
  ASSERT_FALSE(t["pose_views"].empty());
  const auto& first = t["pose_views"][0];
  EXPECT_EQ(first["time"].get<double>(), 0.0);
  EXPECT_EQ(first["width"].get<int>(), 1280);
  EXPECT_GE(first["segments"].get<int>(), first["posed"].get<int>());
  EXPECT_GT(first["seconds"].get<double>(), 0.0);
  EXPECT_GE(first["targets"].size(), 3u);
  EXPECT_LE(first["targets"].size(), 5u);  // the bin's five, not the tray's
  long targets = 0, consistent = 0, good = 0;
  for (const auto& v : t["pose_views"])
    for (const auto& g : v["targets"]) {
      ++targets;
      EXPECT_GE(g["visible_fraction"].get<double>(), 0.1);
      EXPECT_LE(g["visible_fraction"].get<double>(), 1.0);
      if (!g["posed"].get<bool>()) {
        EXPECT_TRUE(g["vsd"].empty());
        continue;
      }
      ASSERT_EQ(g["vsd"].size(), 10u);
      // Two errors that share no code agree: a pose right by MSSD is right by VSD at 0.3 d.
      if (g["mssd"].get<double>() < 0.05 * g["diameter"].get<double>()) ++good, consistent += g["vsd"][5].get<double>() < 0.3;
    }
  EXPECT_GE(good, 3);
  EXPECT_GE(consistent, good * 9 / 10);
  std::ifstream in(d.path() / "out" / "summary.json");
  const nlohmann::json s = nlohmann::json::parse(in);
  const auto& p = s["pose_recall"];
  EXPECT_EQ(p["views"].get<long>(), static_cast<long>(t["pose_views"].size()));
  EXPECT_EQ(p["targets"].get<long>(), targets);
  EXPECT_GE(p["ar"].get<double>(), 0.5) << p.dump();
  EXPECT_LE(p["ar"].get<double>(), 1.0);
  EXPECT_NEAR(p["ar"].get<double>(), (p["ar_vsd"].get<double>() + p["ar_mssd"].get<double>() + p["ar_mspd"].get<double>()) / 3, 1e-12);
  EXPECT_GT(p["seconds_per_view_mean"].get<double>(), 0.0);
  // Re-run from its seed (a dataset's views), the trial is the same but for the wall times.
  const testing_cli::RunResult again = runMinimanip("dataset " + (d.path() / "out").string() + " --views 1");
  EXPECT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("matches its line"), std::string::npos) << again.out;
}

// Two rounds of experiments/known_objects.yaml (seed 1; the noise drawn by Box-Muller, as they were
// found before 2026-12-06) that each ended with objects left before:
// in round 49 the boxes of an object posed on the bin's floor reached below it, and every lift
// "met" the floor (two left); in round 17 the hand stopped twice in a row on one object's slope, pushed it a
// little each time, and the round ended with seven left. Now the lift leaves the cell's parts the
// held mesh's boxes overlap where it is grasped, and after a failed pick the other objects go
// first: both rounds are cleared.
TEST(ModelPose, AMeshsBoxesPastTheFloorAndAFailedPickDoNotEndARound) {
  TempDir d;
  const testing_cli::RunResult r =
      runMinimanip("run experiments/known_objects.yaml --only 17,49 --jobs 1 --set progress=none "
                   "--set perception.depth_noise_sampler=box_muller --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = testing_cli::readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 2u);
  for (const auto& t : trials) {
    EXPECT_TRUE(t["objects_left"].empty()) << t["trial"] << ": " << t["objects_left"].dump() << t["failures"].dump();
    for (const auto& f : t["failures"]) EXPECT_EQ(f["reason"].get<std::string>().find("held object / bin_"), std::string::npos) << f.dump();
  }
  // Round 17's hand still stops on that slope (the failure recorded), and the round goes on.
  const auto& round17 = trials[0]["trial"].get<int>() == 17 ? trials[0] : trials[1];
  bool stopped = false;
  for (const auto& f : round17["failures"]) stopped |= f["kind"].get<std::string>() == "contact_force";
  EXPECT_TRUE(stopped) << round17["failures"].dump();
}

// trees/clutter_removal_model.xml: the grasps of the posed objects' models first, the points'
// when none passes. Round 7 clears its bin, most of it by the models' grasps, and each pick says
// which gave its grasp; a model that gave nothing is a handled failure before a grasp from the points.
TEST(ModelPose, TheModelsGraspsComeFirstAndThePointsAfter) {
  TempDir d;
  const testing_cli::RunResult r = runMinimanip("run experiments/known_objects.yaml --only 7 --set progress=none "
                                                "--set tree=experiments/trees/clutter_removal_model.xml --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = testing_cli::readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 1u);
  const auto& t = trials[0];
  EXPECT_TRUE(t["objects_left"].empty()) << t["objects_left"].dump() << t["failures"].dump();
  int model = 0, points = 0;
  for (const auto& p : t["picks"]) {
    const std::string type = p["grasp_type"].get<std::string>();
    (type == "cloud" ? points : model) += p["placed"].get<bool>();
    EXPECT_NE(type, "external");
  }
  EXPECT_GE(model, 4) << t["picks"].dump();
  EXPECT_GE(points, 1) << t["picks"].dump();
  for (const auto& f : t["failures"]) EXPECT_TRUE(f["handled"].get<bool>()) << f.dump();
}

TEST(ModelPose, KnownModelsOutsideCameraModeOrWithoutMeshesAreExitTwo) {
  TempDir d;
  auto r = runMinimanip("run experiments/known_objects.yaml --trials 1 --set progress=none --set perception.mode=ground_truth --out " +
                        (d.path() / "a").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("known_objects.yaml"));
  EXPECT_THAT(r.out, ::testing::HasSubstr("perception.known_models: expected perception.mode camera"));
  r = runMinimanip("run experiments/known_objects.yaml --trials 1 --set progress=none --set objects.kinds=cube_5cm_grey --out " +
                   (d.path() / "b").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("expected mesh or URDF kinds"));
}

}  // namespace
}  // namespace mm
