// The messages of the process protocol for external components (a user's grasp detector or pose
// estimator, in any language), version 1. The harness writes a view's images to files and sends one
// JSON line on the child's stdin; the child answers one JSON line on its stdout with the same id.
// (The child's process: core/child_process.h.)
//
// Request (one line; keys in this order):
//   {"protocol": 1, "id": 7, "want": "grasps", "trial": 3, "seed": 1,
//    "images": {"depth": "/dev/shm/.../depth.npy", "rgb": ".../rgb.npy" or null, "labels": null},
//    "camera": {"width": 640, "height": 480, "fx": .., "fy": .., "cx": .., "cy": ..,
//               "T_world_camera": [[4 x 4]]},
//    "region": {"T_world_region": [[4 x 4]], "half_extents": [x, y, z]},
//    "gripper": {"stroke": .., "finger_thickness": .., "pad_half_width": .., "pad_z_min": ..,
//                "pad_z_max": .., "hand_back": .., "hand_half_thickness": .., "hand_half_width": ..,
//                "finger_margin": ..},
//    "oracle": null or "segmentation"}
// Images are NumPy .npy files (numpy.load reads them): depth float32 [m] of shape (height, width),
// 0 where there is no depth; rgb uint8 (height, width, 3); labels uint8 (height, width), given only
// in a declared oracle run (core/camera.h's SegmentLabel). Camera frames are OpenCV's (x right, y
// down, z forward); poses are 4 x 4 row-major matrices T_a_b (b's coordinates into a), metres.
// The region is the bin's volume in T_world_region's frame: x within +-half_extents[0], y within
// +-half_extents[1], z from 0 (the bin's floor) up to half_extents[2] (the perception's region: above
// the tallest object the catalogue allows). The gripper is the TCP frame's geometry: z along the approach (into the
// object), the fingers closing along y, the pads from pad_z_min to pad_z_max along z (the tips at
// pad_z_max), the hand body from hand_back behind the TCP. A grasp's opening is the pads' distance
// as the hand comes down: the harness takes the object's width across them as opening less
// finger_margin each side (so a detector that knows the width answers width + 2 finger_margin).
//
// Answer (one line):
//   {"protocol": 1, "id": 7, "frame": "camera" or "world",
//    "grasps": [{"T": [[4 x 4]], "opening": 0.05, "score": 0.9}, ...]}   best first, or
//   {"protocol": 1, "id": 7, "frame": .., "objects": [{"name": "..", "T": [[4 x 4]], "score": ..}]},
//   {"protocol": 1, "id": 7, "error": "why it found nothing"}   (the child's own failure)
// "T" is T_frame_tcp for a grasp (the TCP as above) and T_frame_object for an object; "score" any
// finite number, higher better. Other keys are ignored. Anything else — not JSON, another id or
// version, an unknown frame, a matrix that is not a rigid motion or is placed more than 100 m away,
// an opening outside the stroke, a NaN, more than 10,000 entries — is not the protocol.
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"

namespace mm {

inline constexpr int kExternalProtocolVersion = 1;

/// The frames an answer may use.
enum class ExternalFrame { kCamera, kWorld };
/// "camera" or "world"; false for any other name.
bool parseExternalFrame(const std::string& name, ExternalFrame& out);

struct ExternalGripper {
  double stroke = 0.08;
  double finger_thickness = 0.018, pad_half_width = 0.0105, pad_z_min = -0.045, pad_z_max = 0.009;
  double hand_back = 0.0414, hand_half_thickness = 0.042, hand_half_width = 0.102;
  double finger_margin = 0.012;  ///< the pads open to a grasp's opening; the object's width is taken as that less this each side
};

enum class ExternalWant { kGrasps, kObjects };

struct ExternalRequest {
  uint64_t id = 0;
  ExternalWant want = ExternalWant::kGrasps;
  uint64_t trial = 0, seed = 0;
  std::filesystem::path depth, rgb, labels;  ///< rgb, labels: empty when not given
  CameraModel camera;
  Pose T_world_region = Pose::Identity();
  Vec3 region_half = Vec3::Zero();
  ExternalGripper gripper;
  bool oracle_segmentation = false;  ///< the labels are given: a declared oracle run
};

/// The request as one JSON line (no newline).
std::string requestLine(const ExternalRequest& r);

struct ExternalGrasp {
  Pose T_world_tcp = Pose::Identity();
  double opening = 0;  ///< [m]
  double score = 0;
};

struct ExternalObject {
  std::string name;
  Pose T_world_object = Pose::Identity();
  double score = 0;
};

struct ExternalAnswer {
  ExternalFrame frame = ExternalFrame::kWorld;  ///< the frame the child said it answered in
  std::vector<ExternalGrasp> grasps;    ///< in the world frame, in the child's order
  std::vector<ExternalObject> objects;  ///< in the world frame
  std::string error;                    ///< the child's own failure ("" when it answered)
};

/// Reads one answer line to `request` (its id, its camera for the camera frame, its gripper's stroke).
/// False, with `why` saying what is wrong, when the line is not the protocol.
bool parseAnswer(const std::string& line, const ExternalRequest& request, ExternalAnswer& out, std::string& why);

/// Writes a NumPy .npy file (format 1.0, C order): `dtype` as NumPy spells it ("<f4", "|u1": its
/// last digits are the item's size in bytes), the array's `shape`, and its bytes (their number must
/// be the shape's product times the item size: std::invalid_argument otherwise). OutputError when
/// the file cannot be written.
void writeNpy(const std::filesystem::path& path, const std::string& dtype, const std::vector<size_t>& shape, const void* data,
              size_t bytes);

}  // namespace mm
