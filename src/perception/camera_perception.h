// Object poses from one depth image, with nothing but geometry: no colour, no simulator ids.
//   depth -> points in the world (through the camera extrinsics the caller trusts: calibrated)
//   -> the crop box (the bin, up to crop_height) -> the supporting plane found by RANSAC and removed
//   -> faces: regions grown over points on one plane, within the sensor's noise, flattest seeds
//      first (a cube on another, a tilted cube's two faces part; coplanar touching faces do not)
//   -> per face: its pixels placed where their rays meet its plane; a face the size of a catalogue
//      kind's gets the outline fit (the face's boundary pixels against the rectangle's edges, a 2-D
//      point-to-line ICP over centre, angle and size); otherwise the catalogue's face rectangles
//      are laid along the outline's straight edges and taken by coverage, where the camera does
//      not see past them (several faces side by side, a face partly hidden)
//   -> a box behind each rectangle; one box seen through two faces kept once
//   -> a round face (its hull fills about pi/4 of its bounding square) of a catalogue cylinder's
//      radius: that cylinder standing under it, the disc's centre by a circle fit of its outline
//   -> what no detection explains: obstacles (upright boxes from the floor to the patch's top).
// A 3-D point-to-plane ICP of all the cluster's points against the box's faces was tried instead
// of the outline fit: under the stereo noise model it drifted by up to 3 mm along an axis that only
// a thin visible side constrained. Why faces: docs/design/faces-in-piles.md.
// And the errors of an estimated pose against the truth, as BOP measures them.
#pragma once
#include <string>
#include <vector>

#include "core/camera.h"
#include "core/geometry.h"
#include "core/rng.h"

namespace mm {

/// The kinds that can be in the bin, as the catalogue gives them: boxes (half sizes) and cylinders
/// (radius, radius, half height; found standing upright, by their top disc).
struct KnownShape {
  std::string name;
  Vec3 half_size = Vec3::Zero();
  double mass = 0;
  ObjectShape shape = ObjectShape::kBox;
};

struct CameraPerceptionOptions {
  Pose T_world_crop = Pose::Identity();  ///< the bin: frame on its floor
  Vec3 crop_half = Vec3::Zero();         ///< footprint half sizes (x, y) [m]
  double crop_height = 0.1;              ///< [m] above the floor
  double plane_threshold = 0.008;        ///< [m] points this close to the support plane are the plane
  int min_pixels = 40;                   ///< a face needs this many
  double depth_sigma_k = 0.0015;         ///< the sensor's depth noise as its datasheet gives it: sigma = k z^2 [1/m]
  /// A frame with no depth over more than this share of the bin's image is not perceived (a
  /// blackout, a dropout): the perception fails, saying so, and the tree may look again.
  double max_missing = 0.25;
};

struct CameraDetection {
  ObjectState object;       ///< pose and size (index -1: no identity from a camera)
  int pixels = 0;           ///< the cluster's
  int face_pixels = 0;      ///< the face it was found by
};

struct CameraPerceptionResult {
  bool ok = false;
  std::vector<CameraDetection> detections;
  std::string reason;
  int plane_inliers = 0;
  double missing = 0;  ///< the share of the bin's floor area in the image with no depth
  /// What rises above the floor that no detection explains (an object not recognised, the part of
  /// a pile the camera could not split): each connected patch of such points a box in the world,
  /// upright from the floor to its highest point (what is under a seen surface is unknown, so taken
  /// as occupied), for the planner to avoid.
  std::vector<Obstacle> unexplained;
  /// Wall-clock seconds of each step (benchmarks print them; nothing decides by them): the cloud
  /// in the crop, the floor's RANSAC, growing the faces, fitting and deduplicating the objects, the
  /// unexplained points' patches.
  struct {
    double cloud = 0, floor = 0, faces = 0, fit = 0, unexplained = 0;
  } seconds;
};

/// Detects objects of `shapes` in `frame` (its depth; frame.camera.T_world_camera is the extrinsics
/// used): boxes by their faces, upright cylinders by their top discs. `rng` draws the RANSAC samples.
CameraPerceptionResult detectKnownObjects(const Frame& frame, const std::vector<KnownShape>& shapes,
                                   const CameraPerceptionOptions& options, Rng& rng);

/// How a depth noise's normals are drawn: the ziggurat (Rng::normalsAndUniforms, a 64-bit draw a
/// pixel), or Box-Muller (Rng::boxMullerNormalsAndUniforms, as before 2026-12-06, about 2.5 times
/// the cost: the camera-mode figures measured before then come back with it, number for number).
enum class NoiseSampler { kZiggurat, kBoxMuller };
/// A stereo camera's depth noise: sigma = k z^2 (k [1/m]: 0.0015 gives 1.5 mm at 1 m), and at
/// depth edges (a 3x3 neighbourhood spanning more than `edge_jump`) a pixel is lost with
/// probability `edge_dropout`, as stereo matching fails there.
struct DepthNoise {
  double k = 0.0015;
  double edge_jump = 0.01;      ///< [m]
  double edge_dropout = 0.5;
  NoiseSampler sampler = NoiseSampler::kZiggurat;
};
void applyDepthNoise(Frame& frame, const DepthNoise& noise, Rng& rng);

/// Errors of an estimated box pose against the truth: the centre distance, the rotation error
/// up to the box's symmetries (a cube turned 90 degrees is the same cube: the smallest angle over
/// the rotations that map the box onto itself) and BOP's MSSD (the largest distance of a model
/// vertex between the two poses, minimized over the symmetries) [m, rad, m].
struct PoseError {
  double centre = 0, rotation = 0, mssd = 0;
};
/// A cylinder (half_size: radius, radius, half height) is the same turned any way about its axis
/// and end over end: its rotation error is the angle between the axes, its MSSD taken over points
/// of its two rims and those turns (every 2 degrees).
PoseError poseError(const Pose& estimate, const Pose& truth, const Vec3& half_size, ObjectShape shape = ObjectShape::kBox);

}  // namespace mm
