// Writing rendered frames: PNG images (OpenCV's imgcodecs) and MP4 video (frames piped to ffmpeg).
// File formats, as RGB-D datasets (BOP) write them:
//   <name>.png        8-bit RGB
//   <name>_depth.png  16-bit grey, depth in units of 0.1 mm (kDepthPngScale; 0: no depth; up to 6.5 m)
//   <name>_seg.png    8-bit grey, a SegmentLabel per pixel (0 scene, 1 robot, 2 + k object k, 255 obstacle)
//   previews for a human: depth in a colour map, segmentation in distinct colours.
#pragma once
#include <cstdio>
#include <string>

#include "render/renderer.h"

namespace mm {

constexpr double kDepthPngScale = 1e-4;  ///< [m] per unit of a depth PNG

/// Each writes the frame's image to `path`; throws std::runtime_error if it cannot.
void writeRgbPng(const std::string& path, const Frame& f);
void writeDepthPng(const std::string& path, const Frame& f);
void writeSegmentationPng(const std::string& path, const Frame& f);
/// Depth in the turbo colour map, near to far histogram-equalized (black: none).
void writeDepthPreview(const std::string& path, const Frame& f);
/// Labels in distinct colours (scene dark grey, robot light grey, objects in hues).
void writeSegmentationPreview(const std::string& path, const Frame& f);

/// A box in the world (a finger of a grasp): its centre's pose and half sizes.
struct WorldBox {
  Pose T_world_box = Pose::Identity();
  Vec3 half = Vec3::Zero();
};

/// What a robot made of one view, for a human: the view's depth shaded grey (near light), each
/// segment (`segment`: per pixel 0 for none, k + 1 for the k-th) in its own hue over it with its
/// outline, and `boxes` (the chosen grasp's fingers) drawn as their outlines seen by the view's
/// camera. `view` needs its camera and depth.
void writeSegmentsPicture(const std::string& path, const Frame& view, const std::vector<uint16_t>& segment,
                          const std::vector<WorldBox>& boxes);

/// Reads a depth PNG back [m] (row-major, top row first); throws std::runtime_error.
std::vector<float> readDepthPng(const std::string& path, int* width, int* height);

/// H.264 MP4 through Debian's ffmpeg, at `fps` frames per second of simulated time played in real
/// time: frames are RGB of a fixed size.
class VideoWriter {
 public:
  /// True when an ffmpeg with libx264 can be run (false: say why in `why`).
  static bool available(std::string* why);
  VideoWriter(std::string path, int width, int height, int fps);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;
  void add(const Frame& f);
  /// Ends the stream; throws std::runtime_error when ffmpeg failed. Returns the frames written.
  int close();

 private:
  std::string path_;
  int width_, height_;
  FILE* pipe_ = nullptr;
  int frames_ = 0;
  bool failed_ = false;
};

}  // namespace mm
