// Segmentation of piles of unknown objects, scored against the renderer's labels after BOP: an
// object counts when its visible fraction (its pixels in the view over its pixels alone in the
// same view) is at least 0.5; it is found when a segment's mask has IoU >= 0.5 with its visible
// mask (one segment to one object); a segment that matches no object so is false. Piles of generated objects of every grade, dropped and settled as the
// clutter_pile experiment drops them, seen once from the overhead camera with the stereo noise.
// MM_PILES=N prints the table over N piles (docs/measurements/perception.md); the test asserts on a few.
// MM_MERGE=convexity joins the supervoxels by LCCP's convexity instead of the learned score; with
// it, MM_RECUT=0 leaves LCCP's segments larger than any object whole (another value: its
// tolerance) and MM_SANITY_JOIN=0 leaves them unjoined where faces meet edge on. MM_LEN=0 turns off
// the join of pieces that together fit an object's size (MM_LEN and MM_WID give other sizes).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>

#include <Eigen/Dense>

#include "core/rng.h"
#include "perception/camera_perception.h"
#include "perception/perception.h"
#include "perception/segmentation.h"
#include "render/renderer.h"
#include "../render/test_renderer.h"
#include "object_pixels.h"
#include "../sanitized.h"
#include "sim/object_generator.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"
#include "kinematics/ik.h"
#include "task/pick_place.h"
#include "task/trial_context.h"
#include "campaign/experiment.h"
#include "campaign/trial.h"
#include "sim/hardware.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

using testing_render::renderer;

struct GradeScore {
  int objects = 0, visible = 0, found = 0;
  int found_pixels = 0;  ///< by the segments' own pixels (no mask)
  long long pixels = 0, no_depth = 0;  ///< the visible objects' pixels, and those of them with no depth
};

struct Score {
  std::map<std::string, GradeScore> grades;
  int segments = 0, false_segments = 0;
  int false_pixels = 0;  ///< by the segments' own pixels (no mask)
  double seconds = 0, mask_seconds = 0;
  int views = 0;
};

// A case's change to the options its pile is segmented with, made after the MM_ knobs.
using Tweak = std::function<void(SegmentationOptions&)>;

// A pile as the clutter_pile experiment drops it (`seed`, `trial`), settled, seen once from the
// overhead camera (`width` x `height`): the spawn (spawn.ok false: it did not, and nothing is
// seen), the camera, the frame with the renderer's labels, and the objects' pixels in the view
// before the stereo noise, which `sampler` then draws into the depth (MM_SAMPLER=box_muller: as
// drawn before 2026-12-06, the tables measured then; MM_NOISE_FREE: none).
struct PileView {
  SpawnResult spawn;
  CameraModel cam;
  Frame frame;
  testing_render::ObjectPixels px;
};

PileView viewPile(SimWorld& w, uint64_t seed, uint64_t trial, int width, int height, NoiseSampler sampler) {
  const auto [T_bin, half] = w.site("bin_region");
  SpawnOptions so;
  so.generated.grades = shapeGrades();
  so.count_min = 5, so.count_max = 10;
  so.drop = true;
  so.wall_margin = 0.07;
  so.settle_time = 2.0;
  Rng rng = Rng::stream(seed, trial, Purpose::kScene);
  PileView view;
  view.spawn = spawnObjects(w, panda(), T_bin, half, rng, so);
  if (!view.spawn.ok) return view;
  w.updateKinematics();
  view.cam = renderer().camera(w, "overhead_camera", width, height, "(test)");
  view.frame = renderer().render(w, view.cam, kDepth | kSegmentation);
  view.px = testing_render::objectPixels(w, view.cam, view.spawn.active, view.frame);
  Rng noise = Rng::stream(seed, trial, Purpose::kCamera);
  DepthNoise depth_noise;
  depth_noise.sampler = sampler;
  if (const char* env = std::getenv("MM_SAMPLER"); env && std::string(env) == "box_muller") depth_noise.sampler = NoiseSampler::kBoxMuller;
  if (!std::getenv("MM_NOISE_FREE")) applyDepthNoise(view.frame, depth_noise, noise);
  return view;
}

// `labels`: the oracle's segments (the renderer's labels), else the depth's. `sampler` draws the
// depth's noise.
void scorePile(SimWorld& w, uint64_t seed, uint64_t trial, int width, int height, Score& score, bool verbose, bool labels,
               const Tweak& tweak = {}, NoiseSampler sampler = NoiseSampler::kZiggurat) {
  const auto [T_bin, half] = w.site("bin_region");
  const PileView view = viewPile(w, seed, trial, width, height, sampler);
  const SpawnResult& r = view.spawn;
  if (!r.ok && verbose) {  // the long measurement (MM_PILES) goes on without it: seed 1's pile 38 does not spawn
    std::printf("  pile %llu not scored: %s\n", static_cast<unsigned long long>(trial), r.reason.c_str());
    return;
  }
  ASSERT_TRUE(r.ok) << "pile " << trial << ": " << r.reason;
  const CameraModel& cam = view.cam;
  const Frame& frame = view.frame;
  const size_t n = r.active.size();
  const testing_render::ObjectPixels& px = view.px;

  SegmentationOptions o;
  o.T_world_region = T_bin;
  o.region_half = half;
  // The alternatives LCCP is measured against (docs/measurements/perception.md): MM_SEGMENTER=
  // region_growing or normal_clusters, with MM_NEIGHBOURS, MM_ANGLE, MM_CURVATURE (region growing)
  // and MM_TOLERANCE (clustering) for settings other than their defaults.
  if (const char* m = std::getenv("MM_SEGMENTER")) {
    const std::string name = m;
    ASSERT_TRUE(name == "lccp" || name == "region_growing" || name == "normal_clusters")
        << "MM_SEGMENTER=" << name << ": expected lccp, region_growing or normal_clusters";
    o.method = name == "region_growing" ? SegmentationMethod::kRegionGrowing
               : name == "normal_clusters" ? SegmentationMethod::kNormalClusters : SegmentationMethod::kLccp;
    const bool grow = o.method == SegmentationMethod::kRegionGrowing;
    if (const char* e = std::getenv("MM_NEIGHBOURS")) (grow ? o.grow_neighbours : o.cluster_neighbours) = std::atoi(e);
    if (const char* e = std::getenv("MM_ANGLE")) (grow ? o.grow_angle : o.cluster_angle) = std::atof(e);
    if (const char* e = std::getenv("MM_CURVATURE")) o.grow_curvature = std::atof(e);
    if (const char* e = std::getenv("MM_TOLERANCE")) o.cluster_tolerance = std::atof(e);
  }
  // What an object can measure seen from above: the generated set's own limit, its bounding box's
  // longest side, along and across (as a campaign sets it).
  o.max_object_length = o.max_object_width = SpawnOptions{}.generated.max_extent;
  if (const char* e = std::getenv("MM_LEN")) o.max_object_length = std::atof(e);  // 0: no join by size
  if (const char* e = std::getenv("MM_WID")) o.max_object_width = std::atof(e);
  if (const char* e = std::getenv("MM_RECUT")) o.recut_tolerance = std::atof(e);
  if (const char* e = std::getenv("MM_WAIST")) o.waist_depth = std::atof(e);  // 0: no cut at a waist
  if (const char* e = std::getenv("MM_WAIST_RATIO")) o.waist_ratio = std::atof(e);
  if (const char* e = std::getenv("MM_WAIST_FILL")) o.waist_fill = std::atof(e);  // 0: every segment's outline read
  if (const char* e = std::getenv("MM_WAIST_SMOOTH")) o.waist_smooth = std::atoi(e) != 0;  // 0: a waist smooth in depth cut all the same
  if (const char* e = std::getenv("MM_SPLIT")) o.split_unconnected = std::atoi(e) != 0;  // 0: no cut of a segment whose pixels fall apart
  if (const char* e = std::getenv("MM_CRUMB")) o.crumb_pixels = std::atoi(e);  // 0: no join of a small elongated segment left
  if (const char* e = std::getenv("MM_CRUMB_TOP")) o.crumb_top_step = std::atof(e);  // 0: a crumb joins a neighbour at any height
  if (const char* e = std::getenv("MM_SMOOTH")) o.smooth_step = std::atof(e);  // 0: no join along a smooth border
  if (const char* e = std::getenv("MM_SMOOTH_SHARE")) o.smooth_share = std::atof(e);
  if (const char* e = std::getenv("MM_BRIDGE")) o.bridge_width = std::atof(e);  // 0: no cut at a bridge
  if (const char* e = std::getenv("MM_MIN_AREA")) o.min_area = std::atof(e) * 1e-4;  // [cm^2]; 0: min_pixels alone
  if (const char* e = std::getenv("MM_BRIDGE_CORE")) o.bridge_core_area = std::atof(e);
  if (const char* e = std::getenv("MM_BRIDGE_GAP")) o.bridge_gap = std::atof(e);
  if (const char* e = std::getenv("MM_SANITY_JOIN")) o.sanity_join = std::atof(e);  // 0: LCCP's segments as they are
  if (const char* e = std::getenv("MM_MERGE")) {  // learned (the default) or convexity (LCCP's)
    const std::string merge = e;
    ASSERT_TRUE(merge == "learned" || merge == "convexity") << "MM_MERGE=" << merge << ": expected learned or convexity";
    o.merge = merge == "learned" ? SupervoxelMerge::kLearned : SupervoxelMerge::kConvexity;
  }
  if (tweak) tweak(o);
  auto segment = [&] { return labels ? segmentLabels(frame, o) : segmentDepth(frame, o); };
  const Segmentation seg = segment();
  // The same image, the same segments (PCL on this thread).
  const Segmentation again = segment();
  ASSERT_EQ(again.segments.size(), seg.segments.size());
  for (size_t s = 0; s < seg.segments.size(); ++s) EXPECT_EQ(again.segments[s].pixels, seg.segments[s].pixels);
  // Each segment as the robot knows its object: every point of it inside one of its columns, and
  // every column standing on the bin's floor.
  for (const Segment& sg : seg.segments) {
    const ObjectState ob = segmentObject(sg, T_bin);
    ASSERT_TRUE(ob.pieces && !ob.pieces->empty());
    const Pose T_object_world = ob.T_world_object.inverse();
    int outside = 0;
    for (const Vec3& p : sg.points) {
      const Vec3 q = T_object_world * p;
      bool in = false;
      for (const ConvexPiece& c : *ob.pieces) {
        double worst = -INFINITY;
        for (const auto& [normal, d] : c.planes) worst = std::max(worst, normal.dot(q) - d);
        in = in || worst <= 1e-9;
      }
      outside += !in;
    }
    EXPECT_EQ(outside, 0) << "of " << sg.points.size() << " points";
    for (const ConvexPiece& c : *ob.pieces) {
      double bottom = INFINITY;
      for (const Vec3& v : c.vertices) bottom = std::min(bottom, v.z());
      EXPECT_NEAR((T_bin.inverse() * (ob.T_world_object * Vec3(0, 0, bottom))).z(), 0, 1e-9);
      // It hugs its points: a point on each of its four sides (but where a side was pushed out
      // to keep the box 1 mm thick).
      double low = INFINITY, high = -INFINITY;
      for (const Vec3& v : c.vertices) low = std::min(low, v.z()), high = std::max(high, v.z());
      for (const auto& [normal, d] : c.planes) {
        if (std::abs(normal.z()) > 0.5) continue;
        const auto& opposite = *std::find_if(c.planes.begin(), c.planes.end(), [&](const auto& pl) { return pl.first.dot(normal) < -0.5; });
        if (d + opposite.second <= 1e-3 + 1e-9) continue;
        double nearest = INFINITY;
        for (const Vec3& p : sg.points) {
          const Vec3 q = T_object_world * p;
          bool in = true;
          for (const auto& [n2, d2] : c.planes) in = in && n2.dot(q) - d2 <= 1e-9;
          if (in) nearest = std::min(nearest, d - normal.dot(q));
        }
        EXPECT_LE(nearest, 1e-9) << "a column's side " << normal.transpose() << " clear of its points";
      }
    }
  }
  // The patches too small to be objects rise above the floor's noise, and are seen all the same.
  for (const Segment& sg : seg.small) {
    double area = 0;  // its pixels' footprints at their depths
    for (const Vec3& p : sg.points) {
      const double z = (cam.T_world_camera.inverse() * p).z();
      area += (z / cam.fx) * (z / cam.fy);
    }
    EXPECT_TRUE(static_cast<int>(sg.pixels.size()) < o.min_pixels || area < o.min_area) << sg.pixels.size() << " px, " << area << " m^2";
    EXPECT_GE(static_cast<int>(sg.pixels.size()), o.min_obstacle_pixels);
    EXPECT_GE(sg.top, o.min_obstacle_height);
  }
  score.seconds += seg.seconds;
  ++score.views;
  score.segments += static_cast<int>(seg.segments.size());

  // Each segment's instance mask (its pixels, and the pixels of no depth it takes) is scored; the
  // segments' own pixels alone are scored too (printed, not asserted). IoU of every segment with
  // every object's visible mask; matched greedily, best pair first.
  const auto t_masks = std::chrono::steady_clock::now();
  const std::vector<std::vector<int>> masks = segmentMasks(frame, seg.segments);
  score.mask_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_masks).count();
  for (size_t s = 0; s < seg.segments.size(); ++s) {
    // A mask holds its segment's pixels, and adds only pixels of no depth.
    EXPECT_TRUE(std::includes(masks[s].begin(), masks[s].end(), seg.segments[s].pixels.begin(), seg.segments[s].pixels.end()));
    for (int p : masks[s])
      if (!std::binary_search(seg.segments[s].pixels.begin(), seg.segments[s].pixels.end(), p)) {
        EXPECT_FALSE(frame.depth[static_cast<size_t>(p)] > 0);
      }
  }
  auto match = [&](bool by_masks, std::vector<std::vector<double>>& iou, std::vector<char>& seg_used, std::vector<char>& obj_used) {
    iou.assign(seg.segments.size(), std::vector<double>(n, 0));
    for (size_t s = 0; s < seg.segments.size(); ++s) {
      const std::vector<int>& mask = by_masks ? masks[s] : seg.segments[s].pixels;
      std::vector<int> inter(n, 0);
      for (int pixel : mask) {
        const int l = frame.segmentation[static_cast<size_t>(pixel)];
        for (size_t k = 0; k < n; ++k) inter[k] += l == kSegmentObject0 + r.active[k];
      }
      for (size_t k = 0; k < n; ++k) {
        const int uni = static_cast<int>(mask.size()) + px.visible[k] - inter[k];
        iou[s][k] = uni > 0 ? static_cast<double>(inter[k]) / uni : 0;
      }
    }
    seg_used.assign(seg.segments.size(), 0), obj_used.assign(n, 0);
    for (;;) {
      double best = 0.5;
      int bs = -1, bk = -1;
      for (size_t s = 0; s < seg.segments.size(); ++s)
        for (size_t k = 0; k < n; ++k)
          if (!seg_used[s] && !obj_used[k] && iou[s][k] >= best) best = iou[s][k], bs = static_cast<int>(s), bk = static_cast<int>(k);
      if (bs < 0) break;
      seg_used[static_cast<size_t>(bs)] = obj_used[static_cast<size_t>(bk)] = 1;
    }
  };
  std::vector<std::vector<double>> iou, iou_pixels;
  std::vector<char> seg_used, obj_used, seg_used_pixels, obj_used_pixels;
  match(true, iou, seg_used, obj_used);
  match(false, iou_pixels, seg_used_pixels, obj_used_pixels);
  for (size_t k = 0; k < n; ++k) {
    const std::string grade = r.grades.empty() ? "?" : r.grades[static_cast<size_t>(r.active[k])];
    GradeScore& g = score.grades[grade];
    const double fraction = px.fraction(k);
    ++g.objects;
    if (fraction < 0.5) continue;
    ++g.visible;
    g.found += obj_used[k];
    for (size_t p = 0; p < frame.segmentation.size(); ++p)
      if (frame.segmentation[p] == kSegmentObject0 + r.active[k]) ++g.pixels, g.no_depth += !(frame.depth[p] > 0);
    g.found_pixels += obj_used_pixels[k];
    if (verbose && !obj_used[k]) {
      double best = 0;
      size_t at = 0;
      for (size_t s = 0; s < seg.segments.size(); ++s)
        if (iou[s][k] > best) best = iou[s][k], at = s;
      std::printf("  pile %llu: %s object %zu (visible %.2f, %d px) not found: best IoU %.2f, with a segment of %zu px (%zu with its mask)\n",
                  static_cast<unsigned long long>(trial), grade.c_str(), k, fraction, px.visible[k], best,
                  seg.segments.empty() ? 0 : seg.segments[at].pixels.size(), seg.segments.empty() ? 0 : masks[at].size());
    }
  }
  for (size_t s = 0; s < seg.segments.size(); ++s) {
    score.false_segments += !seg_used[s], score.false_pixels += !seg_used_pixels[s];
    if (!verbose || seg_used[s]) continue;
    // What a false segment holds: the objects its mask covers most, and whether each was found.
    std::map<int, int> cover;
    for (int pixel : masks[s]) ++cover[frame.segmentation[static_cast<size_t>(pixel)]];
    std::printf("  pile %llu: a false segment of %zu px (%zu with its mask):", static_cast<unsigned long long>(trial),
                seg.segments[s].pixels.size(), masks[s].size());
    for (const auto& [l, c] : cover) {
      const auto at = std::find_if(r.active.begin(), r.active.end(), [&](int i) { return kSegmentObject0 + i == l; });
      if (at == r.active.end()) {
        std::printf(" %d px of no object (label %d);", c, l);
        continue;
      }
      const size_t k = static_cast<size_t>(at - r.active.begin());
      std::printf(" %d px of a %s object (IoU %.2f, %s);", c, r.grades.empty() ? "?" : r.grades[static_cast<size_t>(*at)].c_str(), iou[s][k],
                  obj_used[k] ? "found by another" : "not found");
    }
    std::printf("\n");
  }
}

Score scorePiles(int piles, int width, int height, bool verbose, bool labels = false, const Tweak& tweak = {}) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score score;
  const char* seed_env = std::getenv("MM_SEED");  // 1 unless given
  const uint64_t seed = seed_env ? std::strtoull(seed_env, nullptr, 10) : 1;
  for (int t = 0; t < piles; ++t) scorePile(*w, seed, static_cast<uint64_t>(t), width, height, score, verbose, labels, tweak);
  std::printf("%s: %d piles at %dx%d, seed %llu: %d segments, %d false (by the segments' own pixels: %d); %.1f ms a view, the masks %.2f ms\n",
              labels ? "the labels' oracle" : "the depth", piles, width, height, static_cast<unsigned long long>(seed), score.segments, score.false_segments,
              score.false_pixels, 1e3 * score.seconds / std::max(1, score.views), 1e3 * score.mask_seconds / std::max(1, score.views));
  for (const auto& [grade, g] : score.grades)
    std::printf("  %-7s objects %3d, visible >= 0.5: %3d, found %3d (%.1f%%; by the segments' own pixels %3d, %.1f%%); no depth: %.1f%% of their pixels\n",
                grade.c_str(), g.objects, g.visible, g.found, 100.0 * g.found / std::max(1, g.visible), g.found_pixels,
                100.0 * g.found_pixels / std::max(1, g.visible), 100.0 * static_cast<double>(g.no_depth) / static_cast<double>(std::max(1LL, g.pixels)));
  return score;
}

// The figure (MM_PILES=N prints it over N piles); the test asserts it on a few.
TEST(PileSegmentation, FindsTheVisibleUnknownObjectsOfDroppedPiles) {
  const char* env = std::getenv("MM_PILES");
  const int piles = env ? std::atoi(env) : testing_sanitized::sanitizedOr(1, 4);
  const char* wide = std::getenv("MM_WIDTH");  // 640 (x 480) unless given, e.g. 1280 (x 960)
  const int width = wide ? std::atoi(wide) : 640;
  const Score s = scorePiles(piles, width, width * 3 / 4, env != nullptr);
  int visible = 0, found = 0;
  for (const auto& [grade, g] : s.grades) visible += g.visible, found += g.found;
  ASSERT_GT(visible, 0);
  if (std::getenv("MM_SEGMENTER")) return;  // an alternative measured: LCCP's figures below are not its
  // Seed 1's first four piles today, by the masks: 34 of the 34 visible found, 1 false segment of
  // 35 (by the segments' own pixels: 33, and 2 false; seed 1's 39 piles that spawn of 40:
  // docs/measurements/perception.md).
  // The target (95% of the simpler grades found, 85% of the hollow ones, at most 2% of segments
  // false) is not reached yet.
  EXPECT_GE(found, 0.85 * visible);
  EXPECT_LE(s.false_segments, std::max(1, s.segments / 8));
}

// Each connection of a view's supervoxel graph (supervoxelGraph) between two supervoxels each at
// least 80% one object's pixels by the renderer's labels (SegmentLabel: 2 + k object k, 255 an
// obstacle): what the learned merge reads of it, and whether the two are one object's.
struct LabelledConnection {
  ConnectionFeatures features{};
  bool one = false;
};

std::vector<LabelledConnection> labelledConnections(const Frame& frame, const SegmentationOptions& o) {
  const SupervoxelGraph g = supervoxelGraph(frame, o);
  std::vector<int> object(g.pixels.size(), -1);
  for (size_t i = 0; i < g.pixels.size(); ++i) {
    std::map<int, int> count;
    for (int p : g.pixels[i]) ++count[frame.segmentation[static_cast<size_t>(p)]];
    int label = -1, most = 0;
    for (const auto& [l, c] : count)
      if (c > most) label = l, most = c;
    if (label >= 2 && label != 255 && static_cast<double>(most) / static_cast<double>(g.pixels[i].size()) >= 0.8) object[i] = label;
  }
  std::vector<LabelledConnection> out;
  for (const SupervoxelGraph::Connection& c : g.connections) {
    const int a = object[static_cast<size_t>(c.a)], b = object[static_cast<size_t>(c.b)];
    if (a >= 0 && b >= 0) out.push_back({c.features, a == b});
  }
  return out;
}

// The connections of the piles of `seed` (`piles` of them; those that do not spawn left out) at
// 640 x 480, labelled.
std::vector<LabelledConnection> pileConnections(uint64_t seed, int piles) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  const auto [T_bin, half] = w->site("bin_region");
  SegmentationOptions o;
  o.T_world_region = T_bin;
  o.region_half = half;
  std::vector<LabelledConnection> out;
  for (int t = 0; t < piles; ++t) {
    const PileView view = viewPile(*w, seed, static_cast<uint64_t>(t), 640, 480, NoiseSampler::kZiggurat);
    if (!view.spawn.ok) continue;
    const std::vector<LabelledConnection> c = labelledConnections(view.frame, o);
    out.insert(out.end(), c.begin(), c.end());
  }
  return out;
}

double connectionScore(const ConnectionFeatures& weights, const ConnectionFeatures& f) {
  double z = 0;
  for (size_t k = 0; k < f.size(); ++k) z += weights[k] * f[k];
  return z;
}

// The area under the ROC curve of `weights`' scores: the chance that a connection of one object
// scores above one of two (ties: half).
double connectionAuc(const std::vector<LabelledConnection>& data, const ConnectionFeatures& weights) {
  std::vector<std::pair<double, bool>> scored;
  for (const LabelledConnection& c : data) scored.emplace_back(connectionScore(weights, c.features), c.one);
  std::sort(scored.begin(), scored.end());
  double ranks = 0, ones = 0;
  for (size_t i = 0; i < scored.size();) {
    size_t j = i + 1;
    while (j < scored.size() && scored[j].first == scored[i].first) ++j;
    for (size_t k = i; k < j; ++k)
      if (scored[k].second) ranks += (static_cast<double>(i + j) + 1) / 2, ++ones;
    i = j;
  }
  const double twos = static_cast<double>(scored.size()) - ones;
  return (ranks - ones * (ones + 1) / 2) / (ones * twos);
}

// The connection model (kConnectionWeights, fitted on seeds 17-32) on piles of seed 1, which it
// was not fitted on, tells the connections between two supervoxels of one object from those
// between two objects' (the area under its ROC curve; 0.965 on seeds 1, 2 and 5-8's 240 piles,
// docs/measurements/perception.md), and reads finite features only.
TEST(PileSegmentation, TheConnectionModelTellsOneObjectsConnectionsFromTwoObjects) {
  const std::vector<LabelledConnection> data = pileConnections(1, testing_sanitized::sanitizedOr(4, 12));
  int ones = 0;
  for (const LabelledConnection& c : data) {
    ones += c.one;
    for (double f : c.features) ASSERT_TRUE(std::isfinite(f));
  }
  ASSERT_GT(ones, 0);
  ASSERT_LT(ones, static_cast<int>(data.size()));
  const double auc = connectionAuc(data, kConnectionWeights);
  std::printf("%zu connections, %d of one object: AUC %.4f\n", data.size(), ones, auc);
  EXPECT_GE(auc, 0.95);
}

// Seed 1's pile 34: a convex solid and a hollow object side by side, which LCCP's merge (and the
// steps after it) leave as one segment of 561 pixels (IoU 0.47 with each: neither found, the
// segment false). With the learned merge, which sums the scores of all the connections between
// two segments before it joins them: two segments, both objects found.
TEST(PileSegmentation, TheLearnedMergeKeepsApartTwoObjectsLccpJoins) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score convexity, learned;
  scorePile(*w, 1, 34, 640, 480, convexity, false, false, [](SegmentationOptions& o) { o.merge = SupervoxelMerge::kConvexity; });
  scorePile(*w, 1, 34, 640, 480, learned, false, false, [](SegmentationOptions& o) { o.merge = SupervoxelMerge::kLearned; });
  EXPECT_EQ(learned.grades["convex"].found, convexity.grades["convex"].found + 1);
  EXPECT_EQ(learned.grades["hollow"].found, convexity.grades["hollow"].found + 1);
  EXPECT_EQ(learned.false_segments, convexity.false_segments - 1);
}

// Logistic regression of `data` by Newton's method (from all weights 0, at most 50 steps), its
// log-likelihood penalized by l2 / 2 times the weights' squared norm (the constant's too).
ConnectionFeatures fitConnections(const std::vector<LabelledConnection>& data, double l2) {
  const int k = kConnectionFeatures;
  Eigen::MatrixXd X(static_cast<Eigen::Index>(data.size()), k);
  Eigen::VectorXd y(static_cast<Eigen::Index>(data.size()));
  for (size_t i = 0; i < data.size(); ++i) {
    for (int j = 0; j < k; ++j) X(static_cast<Eigen::Index>(i), j) = data[i].features[static_cast<size_t>(j)];
    y(static_cast<Eigen::Index>(i)) = data[i].one ? 1 : 0;
  }
  Eigen::VectorXd w = Eigen::VectorXd::Zero(k);
  for (int step = 0; step < 50; ++step) {
    const Eigen::VectorXd p = (1.0 / (1.0 + (-(X * w).array()).exp())).matrix();
    const Eigen::VectorXd gradient = X.transpose() * (p - y) + l2 * w;
    const Eigen::VectorXd s = (p.array() * (1 - p.array())).matrix();
    const Eigen::MatrixXd hessian = X.transpose() * s.asDiagonal() * X + l2 * Eigen::MatrixXd::Identity(k, k);
    const Eigen::VectorXd dw = hessian.ldlt().solve(gradient);
    w -= dw;
    if (dw.norm() < 1e-8) break;
  }
  ConnectionFeatures out{};
  for (int j = 0; j < k; ++j) out[static_cast<size_t>(j)] = w(j);
  return out;
}

// How kConnectionWeights was fitted (docs/measurements/perception.md), run by hand:
//   build/tests/minimanip_tests --gtest_also_run_disabled_tests --gtest_filter='*DISABLED_FitsTheConnectionModel'
// The connections of the piles of seeds 17-32 (the training set; MM_FIT_SEEDS=first-last for
// others), 40 piles each (MM_PILES), those with every measure finite, fitted with l2 1e-2; printed
// as the constant's initializer, with the area under the ROC curve on them.
TEST(PileSegmentation, DISABLED_FitsTheConnectionModel) {
  int first = 17, last = 32;
  if (const char* e = std::getenv("MM_FIT_SEEDS")) {
    ASSERT_EQ(std::sscanf(e, "%d-%d", &first, &last), 2) << "MM_FIT_SEEDS=" << e << ": expected first-last";
  }
  const char* env = std::getenv("MM_PILES");
  const int piles = env ? std::atoi(env) : 40;
  std::vector<LabelledConnection> data;
  int unmeasured = 0;  // a measure not finite (a supervoxel PCL gave no normal): left out of the fit
  for (int seed = first; seed <= last; ++seed)
    for (const LabelledConnection& c : pileConnections(static_cast<uint64_t>(seed), piles)) {
      if (std::all_of(c.features.begin(), c.features.end(), [](double f) { return std::isfinite(f); }))
        data.push_back(c);
      else
        ++unmeasured;
    }
  int ones = 0;
  for (const LabelledConnection& c : data) ones += c.one;
  const ConnectionFeatures w = fitConnections(data, 1e-2);
  std::printf("seeds %d-%d, %d piles each: %zu connections, %d of one object (%d left out, a measure not finite); AUC %.4f (the built-in "
              "weights: %.4f)\n", first, last, piles, data.size(), ones, unmeasured, connectionAuc(data, w), connectionAuc(data, kConnectionWeights));
  std::printf("const ConnectionFeatures kConnectionWeights{{\n");
  for (size_t j = 0; j < w.size(); ++j) std::printf("%s%.6g,%s", j % 5 == 0 ? "    " : " ", w[j], j % 5 == 4 ? "\n" : "");
  std::printf("}};\n");
}

// The alternatives LCCP was measured against (docs/measurements/perception.md) run, give the same
// segments for the same image (scorePile segments each view twice), and find objects; fewer than
// LCCP on seed 1's piles of the table (there 81.7% and 63.1% of the visible, against 87.9%).
TEST(PileSegmentation, RegionGrowingAndClusteringWithNormalsRunAndRepeat) {
  const int piles = testing_sanitized::sanitizedOr(1, 2);
  const Score clusters = scorePiles(piles, 640, 480, false, false,
      [](SegmentationOptions& o) { o.method = SegmentationMethod::kNormalClusters; });
  const Score grown = scorePiles(piles, 640, 480, false, false,
      [](SegmentationOptions& o) { o.method = SegmentationMethod::kRegionGrowing; });
  for (const Score* s : {&clusters, &grown}) {
    int visible = 0, found = 0;
    for (const auto& [grade, g] : s->grades) visible += g.visible, found += g.found;
    ASSERT_GT(visible, 0);
    EXPECT_GT(s->segments, 0);
    EXPECT_GE(found, (s == &clusters ? 0.6 : 0.3) * visible);
  }
}

// The cases below were found in views whose noise Box-Muller drew (before 2026-12-06): they are
// scored with that noise, the views as they were found.
constexpr NoiseSampler kAsFound = NoiseSampler::kBoxMuller;

// And they were found with LCCP's merge of the supervoxels (SupervoxelMerge::kConvexity, the
// default before 2026-12-08; the learned merge cuts most of these views otherwise): each is
// segmented with it, and `tweak`, as it was found.
Tweak withConvexity(const Tweak& tweak = {}) {
  return [tweak](SegmentationOptions& o) {
    o.merge = SupervoxelMerge::kConvexity;
    if (tweak) tweak(o);
  };
}

// LCCP cuts seed 2's pile 8's cube-like solid in two where its faces meet seen edge on: the
// connections between the halves are convex but refused by LCCP's sanity criterion. Joined, the
// halves are one segment, and the object is found; apart, each half is a false segment. (LCCP's
// segments alone: no join by size.)
TEST(PileSegmentation, TheSanityJoinMakesOneSegmentOfASolidLccpCutsWhereItsFacesMeetEdgeOn) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score apart, joined;
  scorePile(*w, 2, 8, 640, 480, apart, false, false,
      withConvexity([](SegmentationOptions& o) { o.sanity_join = 0.0; o.max_object_length = 0.0; }), kAsFound);
  scorePile(*w, 2, 8, 640, 480, joined, false, false,
      withConvexity([](SegmentationOptions& o) { o.sanity_join = SegmentationOptions{}.sanity_join; o.max_object_length = 0.0; }), kAsFound);
  int found_apart = 0, found_joined = 0;
  for (const auto& [grade, g] : apart.grades) found_apart += g.found;
  for (const auto& [grade, g] : joined.grades) found_joined += g.found;
  EXPECT_EQ(found_joined, found_apart + 1);
  EXPECT_EQ(joined.segments, apart.segments - 1);
  EXPECT_EQ(joined.false_segments, apart.false_segments - 2);
}

// Seed 2's pile 2: LCCP cuts a hollow object in pieces (its walls and its rim, where the surface
// turns concave); none is half of it, so it is not found, and three pieces are false segments.
// Joined while their points together fit what a generated object can measure seen from above
// (max_extent along and across), the pieces are one segment, and the object is found.
TEST(PileSegmentation, PiecesThatTogetherFitAnObjectsSizeAreJoinedIntoOne) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score apart, joined;
  scorePile(*w, 2, 2, 640, 480, apart, false, false, withConvexity([](SegmentationOptions& o) { o.max_object_length = 0.0; }), kAsFound);
  scorePile(*w, 2, 2, 640, 480, joined, false, false,
      withConvexity([](SegmentationOptions& o) { o.max_object_length = ObjectSetOptions{}.max_extent; }), kAsFound);
  int found_apart = 0, found_joined = 0;
  for (const auto& [grade, g] : apart.grades) found_apart += g.found;
  for (const auto& [grade, g] : joined.grades) found_joined += g.found;
  EXPECT_EQ(found_joined, found_apart + 1);
  EXPECT_EQ(joined.false_segments, apart.false_segments - 3);
  EXPECT_EQ(apart.grades["hollow"].found + 1, joined.grades["hollow"].found);
}

// A campaign of generated objects gives its segmentation their own limit both ways: no side of
// an object's bounding box longer than max_extent (not max_width across: a ring is as wide as it
// is long).
TEST(PileSegmentation, ACampaignTakesAGeneratedObjectAsWideAsItIsLong) {
  const Experiment e = loadExperiment("experiments/clutter_pile.yaml", {});
  auto world = loadWorld(e, panda());
  const Cell cell = makeCell(e, panda(), *world);
  ASSERT_TRUE(cell.spawn.generated.enabled());
  EXPECT_LT(cell.spawn.generated.max_width, cell.spawn.generated.max_extent);
  EXPECT_EQ(cell.perception.object_length, cell.spawn.generated.max_extent);
  EXPECT_EQ(cell.perception.object_width, cell.spawn.generated.max_extent);
  const SegmentationOptions so = segmentationOptions(cell.perception);
  EXPECT_EQ(so.max_object_width, cell.spawn.generated.max_extent);
}

// Seed 1's pile 31: LCCP cuts a hollow object into two halves, neither half of it. Their union is
// wider than max_width (5 cm, the piece the fingers close across), but no wider than max_extent,
// what a generated object measures from above along and across: with that limit both ways, as a
// campaign sets it, the halves are joined and the object is found, with two false segments fewer.
TEST(PileSegmentation, AHollowObjectsHalvesAreJoinedThoughWiderThanThePieceTheFingersCloseOn) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score narrow, whole;
  scorePile(*w, 1, 31, 640, 480, narrow, false, false,
      withConvexity([](SegmentationOptions& o) { o.max_object_width = ObjectSetOptions{}.max_width; }), kAsFound);
  scorePile(*w, 1, 31, 640, 480, whole, false, false, withConvexity(), kAsFound);
  EXPECT_EQ(narrow.grades["hollow"].found + 1, whole.grades["hollow"].found);
  EXPECT_EQ(whole.false_segments, narrow.false_segments - 2);
  EXPECT_EQ(whole.segments, narrow.segments - 1);
}

// Seed 1's pile 23: two objects side by side (a blend and a convex solid) that LCCP takes for one
// segment, the valley between their tops concave by less than its 25 degrees. Together they are
// larger than any generated object can be, so the segment is cut again at 12 degrees: two
// segments, each object found. (No cut at a waist, nor where a segment's pixels fall apart, nor at
// a bridge, which would part them too.)
TEST(PileSegmentation, ASegmentLargerThanAnyObjectIsCutAgainAtATighterConcavity) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score whole, cut;
  // The recut alone: the waist, the split of unconnected pixels and the bridge's cut off.
  auto recutOnly = [](double recut) {
    return [recut](SegmentationOptions& o) { o.recut_tolerance = recut, o.waist_depth = 0, o.split_unconnected = false, o.bridge_width = 0; };
  };
  scorePile(*w, 1, 23, 640, 480, whole, false, false, withConvexity(recutOnly(0.0)), kAsFound);
  scorePile(*w, 1, 23, 640, 480, cut, false, false, withConvexity(recutOnly(SegmentationOptions{}.recut_tolerance)), kAsFound);
  int found_whole = 0, found_cut = 0;
  for (const auto& [grade, g] : whole.grades) found_whole += g.found;
  for (const auto& [grade, g] : cut.grades) found_cut += g.found;
  EXPECT_EQ(found_cut, found_whole + 2);
  EXPECT_EQ(cut.segments, whole.segments + 1);
  EXPECT_EQ(cut.false_segments, whole.false_segments - 1);
}

// Seed 1's pile 1: two convex solids side by side that LCCP and the joins leave as one segment
// (IoU 0.49 and 0.46 with each: neither found, the segment false). Seen from above, its outline
// narrows between two concavities where the solids touch; cut there, each solid is its own
// segment and found.
TEST(PileSegmentation, ASegmentOfTwoSolidsSideBySideIsCutAtTheWaistBetweenThem) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score whole, cut;
  scorePile(*w, 1, 1, 640, 480, whole, false, false, withConvexity([](SegmentationOptions& o) { o.waist_depth = 0.0; }));
  scorePile(*w, 1, 1, 640, 480, cut, false, false, withConvexity([](SegmentationOptions& o) { o.waist_depth = SegmentationOptions{}.waist_depth; }));
  EXPECT_EQ(cut.grades["convex"].found, whole.grades["convex"].found + 2);
  EXPECT_EQ(cut.segments, whole.segments + 1);
  EXPECT_EQ(cut.false_segments, whole.false_segments - 1);
}

// Seed 5's pile 11: a hollow object whose wall the camera sees speckled (its pixels among pixels
// of no depth and of the floor's depth), joined into one segment of 254 pixels. The outline of its
// mask is ragged, and two of its notches, a few pixels apart, are as deep as a waist (1 cm): cut
// there, the object is two halves of 129 and 125 pixels, neither found (IoU 0.32 and 0.33), both
// false. The mask fills 0.81 of the pixels its outline encloses (two solids side by side, as in
// seed 1's pile 1 above, fill theirs: 0.996), under waist_fill: no cut, one segment, found. (The
// cut's line is smooth in depth too, which waist_smooth reads: off here, to show the fill alone.)
TEST(PileSegmentation, ASpeckledMasksNotchesAreNoWaist) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score cut, whole;
  scorePile(*w, 5, 11, 640, 480, cut, false, false, withConvexity([](SegmentationOptions& o) { o.waist_fill = 0.0; o.waist_smooth = false; }));
  scorePile(*w, 5, 11, 640, 480, whole, false, false,
      withConvexity([](SegmentationOptions& o) { o.waist_fill = SegmentationOptions{}.waist_fill; o.waist_smooth = false; }));
  EXPECT_EQ(whole.grades["hollow"].found, cut.grades["hollow"].found + 1);
  EXPECT_EQ(whole.segments, cut.segments - 1);
  EXPECT_EQ(whole.false_segments, cut.false_segments - 2);
}

// Seed 1's pile 13: a bent bar lying with its bend up, seen as a V. The joins make it one
// segment, but its outline narrows at the bend between two concavities, a waist, and the cut there
// leaves a piece of 118 pixels, a false segment (the other piece is still matched to the bar).
// Across that cut the depth is smooth (the pixel pairs where the pieces touch are within
// smooth_step of each other's depth, as the smooth join reads a border): one surface narrowing, not
// two objects side by side. Not cut, the bar is one segment, found, and the false segment is gone.
TEST(PileSegmentation, AWaistSmoothInDepthIsNotCut) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score cut, whole;
  scorePile(*w, 1, 13, 640, 480, cut, false, false, withConvexity([](SegmentationOptions& o) { o.waist_smooth = false; }));
  scorePile(*w, 1, 13, 640, 480, whole, false, false, withConvexity([](SegmentationOptions& o) { o.waist_smooth = true; }));
  EXPECT_EQ(whole.grades["bent"].found, cut.grades["bent"].found);
  EXPECT_EQ(whole.segments, cut.segments - 1);
  EXPECT_EQ(whole.false_segments, cut.false_segments - 1);
}

// Seed 1's pile 23: a piece of 32 pixels of a blend another segment found (the camera measured no
// depth between them): at least min_pixels, so an object, and a false segment. Its pixels cover
// less than min_area at their depths: a patch no object explains (an obstacle), not an object;
// the objects found the same.
TEST(PileSegmentation, ASegmentTooSmallByAreaIsAPatchNotAnObject) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score by_pixels, by_area;
  scorePile(*w, 1, 23, 640, 480, by_pixels, false, false, withConvexity([](SegmentationOptions& o) { o.min_area = 0.0; }));
  scorePile(*w, 1, 23, 640, 480, by_area, false, false, withConvexity([](SegmentationOptions& o) { o.min_area = SegmentationOptions{}.min_area; }));
  int found_by_pixels = 0, found_by_area = 0;
  for (const auto& [grade, g] : by_pixels.grades) found_by_pixels += g.found;
  for (const auto& [grade, g] : by_area.grades) found_by_area += g.found;
  EXPECT_EQ(found_by_area, found_by_pixels);
  EXPECT_EQ(by_area.segments, by_pixels.segments - 1);
  EXPECT_EQ(by_area.false_segments, by_pixels.false_segments - 1);
}

// Seed 1's pile 13: two small convex solids side by side (128 and about 130 pixels), their tops
// at about one height. The camera measures no depth along most of the line where they touch, but
// their pixels hang together by a bridge a pixel or two wide, and the outline hardly narrows
// there (no waist): one segment, matched to the larger solid alone. Eroded by a pixel, the
// segment's pixels fall apart into two cores; cut between them, each solid is its own segment and
// found, with no false segment more.
TEST(PileSegmentation, TwoSolidsHeldTogetherByABridgeOfPixelsAreCutApart) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score whole, cut;
  scorePile(*w, 1, 13, 640, 480, whole, false, false, withConvexity([](SegmentationOptions& o) { o.bridge_width = 0.0; }));
  scorePile(*w, 1, 13, 640, 480, cut, false, false, withConvexity([](SegmentationOptions& o) { o.bridge_width = SegmentationOptions{}.bridge_width; }));
  EXPECT_EQ(cut.grades["convex"].found, whole.grades["convex"].found + 1);
  EXPECT_EQ(cut.segments, whole.segments + 1);
  EXPECT_EQ(cut.false_segments, whole.false_segments);
}

// Seed 1's pile 6: a bent bar lying so that LCCP cuts it at its bend, where its surface turns
// concave, into two halves of 150 and 139 pixels (IoU 0.49 and 0.45 with the bar: not found, two
// false segments). Along their principal axes the two together are longer than an object can be
// (an L's diagonal), and neither is a crumb. Across the cut the depth is smooth (most pixels where
// the halves touch are within smooth_step of each other's depth). Joined where they fit an
// object's size in some turn, the bar is one segment, found.
TEST(PileSegmentation, PiecesOfOneSurfaceCutAtItsBendAreJoinedAcrossTheirSmoothBorder) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score apart, joined;
  scorePile(*w, 1, 6, 640, 480, apart, false, false, withConvexity([](SegmentationOptions& o) { o.smooth_step = 0.0; }));
  scorePile(*w, 1, 6, 640, 480, joined, false, false, withConvexity([](SegmentationOptions& o) { o.smooth_step = SegmentationOptions{}.smooth_step; }));
  EXPECT_EQ(joined.grades["bent"].found, apart.grades["bent"].found + 1);
  EXPECT_EQ(joined.false_segments, apart.false_segments - 2);
  EXPECT_EQ(joined.segments, apart.segments - 1);
}

// Seed 1's pile 37: a blend and a convex solid side by side, parted in the image by a line of
// pixels the camera measured no depth at (where they touch). The supervoxels' voxels reach across
// it, and LCCP and the joins cut the pair the other way: two segments, each a part of both (of
// 185 and 60 pixels; neither object found, both segments false). Each one's pixels fall apart
// along that line; cut into their pieces, which the join by size puts together again object by
// object, the two segments are the two objects, both found. (No join of small elongated pieces
// left, which would put the smaller segment into the larger; and every waist cut, smooth in depth
// or not, as when this was found: with waist_smooth, the segments without this cut hold a waist
// smooth in depth, left uncut, one segment and one false segment fewer.)
TEST(PileSegmentation, ASegmentWhosePixelsFallApartInTheImageIsCutIntoItsPieces) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score whole, cut;
  scorePile(*w, 1, 37, 640, 480, whole, false, false,
      withConvexity([](SegmentationOptions& o) { o.split_unconnected = false; o.crumb_pixels = 0; o.waist_smooth = false; }));
  scorePile(*w, 1, 37, 640, 480, cut, false, false,
      withConvexity([](SegmentationOptions& o) { o.split_unconnected = true; o.crumb_pixels = 0; o.waist_smooth = false; }));
  EXPECT_EQ(cut.grades["convex"].found, whole.grades["convex"].found + 1);
  EXPECT_EQ(cut.grades["blend"].found, whole.grades["blend"].found + 1);
  EXPECT_EQ(cut.false_segments, whole.false_segments - 2);
  EXPECT_EQ(cut.segments, whole.segments);
}

// Seed 2's pile 37: LCCP and the cut where pixels fall apart leave a ring as three arcs of 63-70
// pixels, none half of it (no object found, three false segments). Along their principal axes
// two arcs together do not fit an object's size (a ring's arcs curve), so the join by size leaves
// them. Each is small and elongated, a piece of an object rather than a small solid's top: joined
// while the union fits an object's size in some turn, the arcs are the ring, found.
TEST(PileSegmentation, SmallElongatedPiecesLeftAreJoinedWhereTheyFitAnObjectInSomeTurn) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score apart, joined;
  scorePile(*w, 2, 37, 640, 480, apart, false, false, withConvexity([](SegmentationOptions& o) { o.crumb_pixels = 0; }));
  scorePile(*w, 2, 37, 640, 480, joined, false, false, withConvexity([](SegmentationOptions& o) { o.crumb_pixels = SegmentationOptions{}.crumb_pixels; }));
  EXPECT_EQ(joined.grades["hollow"].found, apart.grades["hollow"].found + 1);
  EXPECT_EQ(joined.false_segments, apart.false_segments - 3);
  EXPECT_EQ(joined.segments, apart.segments - 2);
}

// A crumb joins only a neighbour whose top is within crumb_top_step of its own: on seed 1's pile
// 21, what is seen of a small solid beside a taller object (a segment of 70 pixels,
// elongated, its top 3.6 cm below the other's) joins that object with any neighbour allowed, and
// is found as an object of its own with the limit; no segment is false either way.
TEST(PileSegmentation, ACrumbJoinsOnlyANeighbourAtItsHeight) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  Score any, near;
  scorePile(*w, 1, 21, 640, 480, any, false, false, withConvexity([](SegmentationOptions& o) { o.crumb_top_step = 0.0; }));
  scorePile(*w, 1, 21, 640, 480, near, false, false,
      withConvexity([](SegmentationOptions& o) { o.crumb_top_step = SegmentationOptions{}.crumb_top_step; }));
  EXPECT_EQ(near.grades["convex"].found, any.grades["convex"].found + 1);
  EXPECT_EQ(near.false_segments, any.false_segments);
  EXPECT_EQ(near.segments, any.segments + 1);
}

// The oracle's segments (perception.segmentation: labels), from the same noisy depth: every object
// visible enough found, no segment false. What the depth's segmentation is scored against.
TEST(PileSegmentation, TheLabelsOracleFindsEveryVisibleObjectAndNoFalseSegment) {
  const Score s = scorePiles(testing_sanitized::sanitizedOr(1, 4), 640, 480, false, true);
  int visible = 0, found = 0;
  for (const auto& [grade, g] : s.grades) visible += g.visible, found += g.found;
  ASSERT_GT(visible, 0);
  EXPECT_EQ(found, visible);
  EXPECT_EQ(s.false_segments, 0);
}

// A drawn depth image: '.' the floor (depth), 'a' / 'b' segment A's or B's pixel (depth), '0' no
// depth; the segments and the frame.
struct DrawnView {
  Frame frame;
  std::vector<Segment> segments;
  int width = 0;
  bool in(const std::vector<int>& mask, int u, int v) const { return std::binary_search(mask.begin(), mask.end(), v * width + u); }
};
DrawnView drawnView(const std::vector<std::string>& rows) {
  DrawnView d;
  d.width = static_cast<int>(rows[0].size());
  d.frame.camera.width = d.width, d.frame.camera.height = static_cast<int>(rows.size());
  d.segments.resize(2);
  for (int v = 0; v < d.frame.camera.height; ++v)
    for (int u = 0; u < d.width; ++u) {
      const char c = rows[static_cast<size_t>(v)][static_cast<size_t>(u)];
      d.frame.depth.push_back(c == '0' ? 0.0f : 1.0f);
      if (c == 'a' || c == 'b') d.segments[c == 'a' ? 0 : 1].pixels.push_back(v * d.width + u);
    }
  return d;
}

// The masks (segmentMasks) on drawn depth images. In the first, of 12 x 8 pixels: segment A a
// block of 4 x 4 pixels with a hole of no depth in it, its left column of no depth where it meets
// the floor (a depth edge's dropout), and segment B two pixels right of A, the column between
// them of no depth. A takes its hole; none of the column by the floor (as much floor about each
// pixel as A, or more); A and B share the column between them by their neighbours.
TEST(PileSegmentation, AMaskTakesThePixelsOfNoDepthItsSegmentHoldsAndNotTheFloors) {
  const DrawnView d = drawnView({
      "............",  //
      "..0aaaa0bb..",  //
      "..0a0aa0bb..",  //
      "..0aaaa0bb..",  //
      "..0aaaa0bb..",  //
      "............",  //
      "............",  //
      "............"});
  const std::vector<std::vector<int>> masks = segmentMasks(d.frame, d.segments);
  ASSERT_EQ(masks.size(), 2u);
  for (const std::vector<int>& m : masks) EXPECT_TRUE(std::is_sorted(m.begin(), m.end()));
  EXPECT_TRUE(d.in(masks[0], 4, 2));  // the hole: all eight neighbours A's
  // The left column: (2, 2) and (2, 3) have three of A about them against three of the floor's
  // and two of no depth: a tie, the floor's. (2, 1) and (2, 4) have five of the floor's.
  for (int v = 1; v <= 4; ++v) EXPECT_FALSE(d.in(masks[0], 2, v)) << v;
  // The column between A and B: (7, 2) and (7, 3) have three of each about them, a tie between
  // segments, the first's. (7, 1) and (7, 4) have three of the floor's against two and two, and
  // at the second pass three against A's three: a tie, the floor's.
  EXPECT_TRUE(d.in(masks[0], 7, 2) && d.in(masks[0], 7, 3));
  EXPECT_FALSE(d.in(masks[0], 7, 1) || d.in(masks[1], 7, 1) || d.in(masks[0], 7, 4) || d.in(masks[1], 7, 4));
  // Nothing else is added: A is its 15 pixels, its hole and two of the column; B is its own.
  EXPECT_EQ(masks[0].size(), d.segments[0].pixels.size() + 3);
  EXPECT_EQ(masks[1], d.segments[1].pixels);
  // No pass: the segments' own pixels.
  EXPECT_EQ(segmentMasks(d.frame, d.segments, 0)[0], d.segments[0].pixels);

  // The second, of 20 x 12 pixels, the segment away from the image's corner: a strip of no depth
  // two pixels wide through segment A (a thin wall's dropout). The first pass takes its three
  // middle rows (three of A about each, no floor); its end pixels have three of the floor's about
  // them against two of A's, and only after that pass four of A's: the second pass takes them.
  const DrawnView e = drawnView({
      "....................",  //
      "....................",  //
      "....................",  //
      "....................",  //
      "........aaaa00aa....",  //
      "........aaaa00aa....",  //
      "........aaaa00aa....",  //
      "........aaaa00aa....",  //
      "........aaaa00aa....",  //
      "....................",  //
      "....................",  //
      "...................."});
  const std::vector<int> one = segmentMasks(e.frame, e.segments, 1)[0], all = segmentMasks(e.frame, e.segments)[0];
  for (int u : {12, 13}) {
    for (int v = 5; v <= 7; ++v) EXPECT_TRUE(e.in(one, u, v)) << u << " " << v;
    for (int v : {4, 8}) EXPECT_FALSE(e.in(one, u, v)) << u << " " << v;  // a pass reads the labels as they were before it
    for (int v = 4; v <= 8; ++v) EXPECT_TRUE(e.in(all, u, v)) << u << " " << v;
  }
  EXPECT_EQ(one.size(), e.segments[0].pixels.size() + 6);
  EXPECT_EQ(all.size(), e.segments[0].pixels.size() + 10);
}

// The arm with its TCP 3 cm over the bin floor's centre, pointing down as at home, the fingers
// 2 cm open (set only when the IK solves).
IkResult putHandInBin(SimWorld& w, const Pose& T_bin) {
  IkRequest req;
  req.target = makePose(T_bin * Vec3(0, 0, 0.03), panda().fk(panda().home()).linear());
  req.seed = panda().home();
  Rng rng(1);
  const IkResult ik = makeIkSolver("auto", panda())->solve(req, rng);
  if (!ik.ok()) return ik;
  w.setArm(ik.q());
  w.setFingers(0.02);
  w.updateKinematics();
  return ik;
}

// The robot's own points (removeRobotPoints, the self filter of the views segmented and of those the
// model-free grasps read): with the hand down in the empty bin, the depth's segmentation makes an
// object of it; with the robot's points taken out at the joint positions it measures, of nothing.
TEST(PileSegmentation, AnArmLeftInTheBinIsTakenOutOfItsView) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  const auto [T_bin, half] = w->site("bin_region");
  const IkResult ik = putHandInBin(*w, T_bin);
  ASSERT_TRUE(ik.ok()) << ik.reason;
  const CameraModel cam = renderer().camera(*w, "overhead_camera", 640, 480, "(test)");
  Frame frame = renderer().render(*w, cam, kDepth);
  Rng noise(2);
  applyDepthNoise(frame, DepthNoise{}, noise);
  SegmentationOptions o;
  o.T_world_region = T_bin;
  o.region_half = half;
  EXPECT_GE(segmentDepth(frame, o).segments.size(), 1u) << "the hand, seen as an object";
  PerceptionOptions po;
  po.T_world_crop = T_bin;
  po.crop_half = half;
  po.crop_height = 0.24;
  removeRobotPoints(panda(), ik.q(), 0.02, po, frame);
  const Segmentation after = segmentDepth(frame, o);
  EXPECT_EQ(after.segments.size(), 0u);
  EXPECT_EQ(after.small.size(), 0u);
}

// The same through the view a trial's segmentation and model-free grasps read (captureView): the
// camera renders the arm in the bin, and the robot takes its own points out at the joint positions
// and the finger opening its hardware measures, with the truth closed (a read would throw).
TEST(PileSegmentation, TheViewATrialSegmentsHasTheArmTakenOutAtTheJointsItMeasures) {
  const Experiment e = loadExperiment("experiments/clutter_pile.yaml", {"perception.mode=camera"});
  auto w = loadWorld(e, panda());
  const Cell cell = makeCell(e, panda(), *w);
  const IkResult ik = putHandInBin(*w, cell.T_world_bin);
  ASSERT_TRUE(ik.ok()) << ik.reason;
  auto hw = makeMujocoHardware(*w, panda(), {});
  Rng noise(2);
  hw->setCameraSource([&](const std::string& name, int width, int height, Frame& frame, std::string*) {
    frame = renderer().render(*w, renderer().camera(*w, name, width, height, "(test)"), kDepth);
    applyDepthNoise(frame, e.perception.noise, noise);
    return true;
  });
  hw->guardTruth(true);
  TrialContext ctx(*hw, panda(), cell.statics, e.task, cell.perception, e.seed, 0);
  SegmentationOptions o;
  o.T_world_region = cell.T_world_bin;
  o.region_half = cell.bin_half;
  std::string why;
  Frame raw;
  ASSERT_TRUE(hw->capture(cell.perception.camera, cell.perception.camera_width, cell.perception.camera_height, raw, &why)) << why;
  EXPECT_GE(segmentDepth(raw, o).segments.size(), 1u) << "the hand, seen as an object";
  Frame view;
  ASSERT_TRUE(captureView(ctx, view, &why)) << why;
  const Segmentation seen = segmentDepth(view, o);
  EXPECT_EQ(seen.segments.size(), 0u);
  EXPECT_EQ(seen.small.size(), 0u);
}

// An empty bin seen through the stereo noise, as trials see it: the floor's noise is neither an object nor an
// obstacle (a patch of it would keep the bin from being empty, and block grasps).
TEST(PileSegmentation, AnEmptyBinsNoiseIsNeitherAnObjectNorAnObstacle) {
  auto w = SimWorld::load("scenes/bin_clearing.xml", panda());
  const auto [T_bin, half] = w->site("bin_region");
  SpawnOptions so;
  so.count_min = so.count_max = 0;
  Rng rng = Rng::stream(1, 0, Purpose::kScene);
  const SpawnResult r = spawnObjects(*w, panda(), T_bin, half, rng, so);
  ASSERT_TRUE(r.ok) << r.reason;
  w->updateKinematics();
  const PerceptionOptions trials;  // at the trials' resolution (more pixels: more noise patches of a given size)
  const CameraModel cam = renderer().camera(*w, "overhead_camera", trials.camera_width, trials.camera_height, "(test)");
  const Frame clean = renderer().render(*w, cam, kDepth);
  SegmentationOptions o;
  o.T_world_region = T_bin;
  o.region_half = half;
  for (uint64_t view = 0; view < static_cast<uint64_t>(testing_sanitized::sanitizedOr(2, 10)); ++view) {
    Frame frame = clean;
    Rng noise = Rng::stream(1, view, Purpose::kCamera);
    applyDepthNoise(frame, DepthNoise{}, noise);
    const Segmentation seg = segmentDepth(frame, o);
    EXPECT_EQ(seg.segments.size(), 0u) << "view " << view;
    EXPECT_EQ(seg.small.size(), 0u) << "view " << view;
  }
}

}  // namespace
}  // namespace mm
