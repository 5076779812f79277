// Perception modes, as the source's three phases: hardcoded (a fixed pose, no sensing), ground
// truth from the simulator (optionally with Gaussian noise), and a camera's depth image
// (perception/camera_perception.h).
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/geometry.h"
#include "core/rng.h"
#include "perception/camera_perception.h"
#include "perception/segmentation.h"

namespace mm {

class ModelPoseEstimator;  // perception/model_pose.h

enum class PerceptionMode { kHardcoded, kGroundTruth, kCamera };
/// Where camera mode's segments of objects with no model come from.
enum class SegmentationSource { kDepth, kLabels };

struct PerceptionOptions {
  /// Keys mode, noise_position, noise_yaw (section "perception").
  void declare(ConfigArchive& a);
  PerceptionMode mode = PerceptionMode::kGroundTruth;
  double noise_position = 0.0;  ///< [m] std of Gaussian noise on x and y
  double noise_yaw = 0.0;       ///< [rad] std of Gaussian noise on yaw
  Pose hardcoded_pose = Pose::Identity();  ///< T_world_object assumed by the hardcoded mode
  Vec3 hardcoded_half = Vec3::Constant(0.025);
  /// What the sensor looks at (the bin): a box whose frame sits on the bin floor, half sizes
  /// (x, y) of the footprint; objects whose centre lies over the footprint and less than
  /// `crop_height` above the floor are seen. Unset (zero footprint): everything is seen.
  Pose T_world_crop = Pose::Identity();
  Vec3 crop_half = Vec3::Zero();
  double crop_height = 0;  ///< [m]; 0: three of the tallest of the experiment's kinds stacked, at least 0.1 (the campaign sets it)
  // Camera mode.
  std::string camera = "overhead_camera";
  int camera_width = 1280, camera_height = 960;  ///< [px]
  DepthNoise noise;  ///< the sensor's (applied where the image is made)
  double max_missing_depth = 0.25;  ///< a frame with no depth over more than this share of the bin is not perceived
  /// [m] the camera registered against the cell in a frame moves a point of the bin (its floor's
  /// and its crop's corners) further than this from where the extrinsics put it: the camera has
  /// moved (knocked off its mount), and the frame is not perceived.
  double max_extrinsics_error = 0.002;
  std::string extrinsics = "simulator";  ///< a file from `minimanip calibrate`, or "simulator": where the scene mounts the camera
  bool calibrated = false;  ///< T_world_camera holds the file's extrinsics
  Pose T_world_camera = Pose::Identity();
  std::vector<KnownShape> shapes;  ///< the kinds that can be in the bin (the experiment's catalogue kinds)
  /// The bin holds objects the robot has no model of (generated, or meshes): the depth is cut into
  /// segments (perception/segmentation.h), each known as the columns under its points (segmentObject).
  bool unknown_objects = false;
  /// [m] What one of the bin's objects can measure seen from above, along and across (a generated
  /// set's max_extent both ways; 0: not known): neighbouring segments that together fit are
  /// taken for pieces of one object (SegmentationOptions::max_object_length; the campaign sets it).
  double object_length = 0, object_width = 0;
  /// The depth cut into segments (segmentDepth); or an oracle's, the renderer's per-object labels
  /// (segmentLabels), which no real camera gives: it measures what segmentation loses.
  SegmentationSource segmentation = SegmentationSource::kDepth;
  /// The mesh kinds are known objects, their meshes the CAD models a real cell's robot has: camera
  /// mode poses each depth segment by them (perception/model_pose.h) before it takes the segment
  /// for an unknown object (key known_models).
  bool known_models = false;
  std::shared_ptr<const ModelPoseEstimator> models;  ///< the kinds' models, when known_models (the campaign builds it)
};

/// How camera mode segments the depth of the bin (segmentDepth): the crop's region, what an object
/// can measure, and for known objects (known_models) no join of faces seen edge on.
SegmentationOptions segmentationOptions(const PerceptionOptions& o);

/// True when the robot knows the objects only as the depth's segments (camera mode, no model):
/// their truth matched loosely, no orientation of theirs known.
inline bool segmentedObjects(const PerceptionOptions& o) { return o.mode == PerceptionMode::kCamera && o.unknown_objects; }

/// True when `o` lies inside the sensor's crop box (see PerceptionOptions).
bool insideCrop(const ObjectState& o, const PerceptionOptions& options);

struct PerceptionResult {
  bool ok = false;
  std::vector<ObjectState> objects;  ///< perceived poses (world frame)
  std::string reason;
};

/// `truth` is the simulator's ground truth of the objects in play; the hardcoded mode ignores it
/// and reports one object at the configured pose.
PerceptionResult perceive(const std::vector<ObjectState>& truth, const PerceptionOptions& options, Rng& rng);

}  // namespace mm
