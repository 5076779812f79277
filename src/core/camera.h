// Camera images as the harness passes them around (rendered by render/, read by perception/),
// and their conventions:
// - Images are row-major with the top row first (as OpenCV's cv::Mat), pixel (u, v) = (column, row).
// - Camera frames are OpenCV's: x right, y down, z along the optical axis.
// - The pinhole model has square pixels, fx = fy, and the principal point at the image centre,
//   cx = (width-1)/2, cy = (height-1)/2, in the convention where pixel (0,0)'s centre is at (0,0).
// - Depth is the z coordinate in the camera frame [m] (not the ray length); 0: no depth there.
// - Segmentation holds a label per pixel: 0 scene, 1 robot, 2 + k object k, 255 an obstacle
//   (sim/sim_world.h's SegmentLabel). Ground truth: for evaluation and pictures, never for perception.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/geometry.h"

namespace mm {

/// A camera of the scene, as an image's geometry.
struct CameraModel {
  std::string name;
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< [px]
  Pose T_world_camera = Pose::Identity();  ///< OpenCV's camera frame
  /// Pixel (u, v) and depth z [m] of a world point.
  Vec3 project(const Vec3& p_world) const;
  /// The same of a point in the camera's frame (a caller projecting many takes the inverse once).
  Vec3 projectFromCamera(const Vec3& p_camera) const;
  /// The world point at pixel (u, v) and depth z [m].
  Vec3 unproject(double u, double v, double z) const;
};

/// A rectangle of pixels, corners included: columns u0..u1, rows v0..v1 (empty if u1 < u0).
struct PixelRect {
  int u0 = 0, v0 = 0, u1 = -1, v1 = -1;
};

/// The pixels through which `cam` can see the box [lo, hi] of the frame T_world_box: the bounding
/// rectangle of its corners' projections, a pixel wider, within the image (the whole image if a
/// corner is not in front of the camera). A point of the box projects inside it.
PixelRect boxPixels(const CameraModel& cam, const Pose& T_world_box, const Vec3& lo, const Vec3& hi);

/// One rendered view; the vectors that were not asked for stay empty.
struct Frame {
  CameraModel camera;
  double time = 0;                     ///< [s] simulated
  std::vector<uint8_t> rgb;            ///< width * height * 3
  std::vector<float> depth;            ///< [m] width * height
  std::vector<uint8_t> segmentation;   ///< SegmentLabel, width * height
};

enum ImageKind : unsigned { kRgb = 1, kDepth = 2, kSegmentation = 4 };

}  // namespace mm
