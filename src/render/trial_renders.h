// A trial's pictures: PNG key frames at the end of chosen stages and an MP4 of the whole trial,
// written under <results>/renders/trial_<N>/. Rendering reads the world and never changes it, so
// a trial's outcome is the same with rendering on or off.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/config.h"
#include "render/image_io.h"
#include "render/renderer.h"
#include "sim/hardware.h"

namespace mm {

class VideoWriter;

/// Section "render" of an experiment.
struct RenderOptions {
  void declare(ConfigArchive& a);
  /// Rendering asked for at all (key frames or video).
  bool enabled() const { return !keyframes.empty() || video; }
  /// Trial `t` is rendered.
  bool renders(uint64_t t) const;

  std::vector<std::string> keyframes;           ///< stage names (and "end"); empty: none
  std::vector<std::string> images = {"rgb"};    ///< rgb, depth, segmentation, segments
  bool video = false;
  int fps = 25;                                 ///< divides the 500 Hz control rate
  std::vector<int64_t> trials;                  ///< empty: every trial
  std::string camera = "overhead_camera";
  int width = 640, height = 480;
  std::string egl = "auto";
  bool previews = false;                        ///< also colour previews of depth and segmentation
};

/// The renders of one trial. Install with wrap(); call stageEnded() as stages end and finish() at
/// the end of the trial.
class TrialRenders {
 public:
  /// `dir`: the trial's folder (made here). `file`: the experiment, for errors.
  TrialRenders(Renderer& renderer, SimWorld& world, const RenderOptions& options, std::string dir, const std::string& file);
  ~TrialRenders();
  /// A Hardware that calls `before_step` before each control period and records video frames.
  Hardware& wrap(Hardware& inner, std::function<void()> before_step);
  /// A stage ended: a key frame if it is one of options.keyframes.
  void stageEnded(const std::string& stage);
  /// The image "segments" asks for what the robot made of its last view (writeSegmentsPicture).
  bool wantsSegments() const { return segments_; }
  /// That view, its segments and the chosen grasp's fingers (empty: none yet), as they are now.
  void setSegments(std::shared_ptr<const Frame> view, std::shared_ptr<const std::vector<uint16_t>> segment, std::vector<WorldBox> fingers);
  /// The trial ended: the "end" key frame, the video closed. Returns the files written (relative to dir).
  std::vector<std::string> finish();

 private:
  class Tap;
  void keyFrame(const std::string& label);
  void afterStep();
  Renderer& renderer_;
  SimWorld& world_;
  const RenderOptions& options_;
  std::string dir_;
  CameraModel camera_;
  unsigned kinds_ = 0;
  bool segments_ = false;
  std::shared_ptr<const Frame> view_;
  std::shared_ptr<const std::vector<uint16_t>> segment_;
  std::vector<WorldBox> fingers_;
  int count_ = 0;           ///< key frames so far
  long steps_ = 0;
  int steps_per_frame_ = 1;
  std::unique_ptr<VideoWriter> video_;
  std::unique_ptr<Tap> tap_;
  std::vector<std::string> files_;
};

}  // namespace mm
