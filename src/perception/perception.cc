#include "perception/perception.h"

#include <cmath>

namespace mm {

void PerceptionOptions::declare(ConfigArchive& a) {
  a.named("mode", mode,
          {{"hardcoded", PerceptionMode::kHardcoded}, {"ground_truth", PerceptionMode::kGroundTruth}, {"camera", PerceptionMode::kCamera}},
          "hardcoded: assume the object at the bin center, yaw 0; ground_truth: simulator poses; camera: boxes found in the "
          "depth image of `camera` by geometry alone (support plane, planar faces, the catalogue's box faces and upright cylinders' "
          "discs fitted to them; no colour, no simulator ids)");
  a.value("noise_position", noise_position, {0.0, 0.05}, "m", "std of Gaussian noise on perceived x and y");
  a.value("noise_yaw", noise_yaw, {0.0, 0.5}, "rad", "std of Gaussian noise on perceived yaw");
  a.value("camera", camera, "camera mode: the scene's camera perception reads");
  a.value("camera_width", camera_width, {64, 4096}, "px", "camera mode: image width");
  a.value("camera_height", camera_height, {48, 4096}, "px", "camera mode: image height");
  a.value("depth_noise", noise.k, {0.0, 0.05}, "1/m",
          "camera mode: a stereo camera's depth noise, sigma = k z^2 (0.0015: 1.5 mm at 1 m, 2.4 mm at the bin's 1.27 m); 0: none. "
          "The perception and grasp detection read it as the sensor's datasheet (cloud grasps: the floor's points facing up "
          "within 3 sigma of it are its plane, not obstacles)");
  a.path("extrinsics", extrinsics,
         "camera mode: the camera's pose as `minimanip calibrate` wrote it (results/calibration/<camera>_extrinsics.yaml); "
         "simulator: where the scene mounts the camera (a camera knocked off its mount, the extrinsics_drift fault, is elsewhere)");
  a.value("crop_height", crop_height, {0.0, 2.0}, "m",
          "what the sensor looks at rises this far above the bin floor (objects whose centre is lower count as in the bin; the "
          "camera's points higher are left out); 0: three of the tallest of the experiment's object kinds stacked (a pile), at "
          "least 0.1");
  a.value("max_missing_depth", max_missing_depth, {0.0, 1.0}, "",
          "camera mode: a frame with no depth over more than this share of the bin's floor area is not perceived (a blackout, a "
          "dropout): the perception fails saying so, and a recovering tree looks again");
  a.value("max_extrinsics_error", max_extrinsics_error, {0.0, 0.05}, "m",
          "camera mode: each frame is checked against the cell's known static parts (the camera registered against them, "
          "perception/cell_registration.h); if that moves a point of the bin further than this from where the extrinsics put it, "
          "the camera has moved (knocked off its mount): the perception fails saying so, and a recovering tree registers the "
          "camera again (RegisterCamera); 0: no check");
  a.named("segmentation", segmentation, {{"depth", SegmentationSource::kDepth}, {"labels", SegmentationSource::kLabels}},
          "camera mode, objects with no model: depth: the depth image cut into segments (supervoxels and LCCP); labels: an "
          "oracle, the renderer's per-object labels cut the same points into one segment per object (no real camera has "
          "them: with depth_noise 0 and edge_dropout 0 it separates what perception loses from what grasping loses)");
  a.value("known_models", known_models,
          "camera mode: the mesh kinds are known objects (their meshes the CAD models a real cell has): each depth segment is "
          "posed by them (point-pair features, ICP, checked against the depth image; perception/model_pose.h) and grasped as the "
          "model; a segment no model explains is an unknown object; false: every mesh object is unknown (its segment's columns)");
  a.value("edge_dropout", noise.edge_dropout, {0.0, 1.0}, "",
          "camera mode: the chance a pixel at a depth edge (its 3x3 neighbourhood spanning more than 1 cm) has no depth, as stereo matching fails there");
  a.named("depth_noise_sampler", noise.sampler, {{"ziggurat", NoiseSampler::kZiggurat}, {"box_muller", NoiseSampler::kBoxMuller}},
          "camera mode: how the depth noise's normals are drawn, one a pixel: ziggurat (a 64-bit draw a pixel, the default since "
          "2026-12-06); box_muller (as before then, about 2.5 times the cost: the camera-mode figures measured before then come back "
          "with it, number for number)");
}

SegmentationOptions segmentationOptions(const PerceptionOptions& o) {
  SegmentationOptions so;
  so.T_world_region = o.T_world_crop;
  so.region_half = o.crop_half;
  so.region_height = o.crop_height;
  so.max_object_length = o.object_length;
  so.max_object_width = o.object_width;
  // Known objects: the models pose LCCP's own segments (a pose takes the pixels it explains, and
  // what it leaves is posed again), as their measurements were made; the joins were measured on
  // generated objects only, and so were the second cut of a segment larger than any object, the
  // cut of a segment whose pixels fall apart, the joins of small elongated pieces and across a
  // smooth border, and the cuts at a waist and at a bridge.
  if (o.known_models)
    so.sanity_join = 0, so.recut_tolerance = 0, so.split_unconnected = false, so.crumb_pixels = 0, so.smooth_step = 0, so.waist_depth = 0,
        so.bridge_width = 0;
  // The learned merge of the supervoxels was fitted and measured on generated objects, within
  // their size limits: known objects, and the catalogue's and mesh kinds (no size limits), keep
  // LCCP's, as they were measured.
  if (o.known_models || o.object_length <= 0 || o.object_width <= 0) so.merge = SupervoxelMerge::kConvexity;
  return so;
}

bool insideCrop(const ObjectState& o, const PerceptionOptions& opt) {
  if (opt.crop_half.x() <= 0 || opt.crop_half.y() <= 0) return true;
  const Vec3 p = opt.T_world_crop.inverse() * o.T_world_object.translation();
  constexpr double kMargin = 0.01;  // [m] a centre this far over the footprint's edge still counts
  return std::abs(p.x()) <= opt.crop_half.x() + kMargin && std::abs(p.y()) <= opt.crop_half.y() + kMargin &&
         p.z() > -kMargin && p.z() < opt.crop_height;
}

PerceptionResult perceive(const std::vector<ObjectState>& truth, const PerceptionOptions& o, Rng& rng) {
  PerceptionResult r;
  if (o.mode == PerceptionMode::kHardcoded) {
    ObjectState s;
    s.index = truth.empty() ? -1 : truth.front().index;
    s.name = truth.empty() ? "hardcoded" : truth.front().name;
    s.T_world_object = o.hardcoded_pose;
    s.half_size = o.hardcoded_half;
    r.objects.push_back(s);
    r.ok = true;
    return r;
  }
  for (ObjectState s : truth) {
    if (!insideCrop(s, o)) continue;
    if (o.noise_position > 0 || o.noise_yaw > 0) {
      s.T_world_object.translation().x() += rng.normal(0, o.noise_position);
      s.T_world_object.translation().y() += rng.normal(0, o.noise_position);
      s.T_world_object.linear() = rotZ(rng.normal(0, o.noise_yaw)) * s.T_world_object.linear();
    }
    r.objects.push_back(s);
  }
  r.ok = !r.objects.empty();
  if (!r.ok) r.reason = "no object detected";
  return r;
}

}  // namespace mm
