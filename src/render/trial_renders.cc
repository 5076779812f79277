#include "render/trial_renders.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/error.h"
#include "core/file_io.h"
#include "render/image_io.h"
#include "sim/sim_world.h"

namespace mm {

void RenderOptions::declare(ConfigArchive& a) {
  a.list("keyframes", keyframes, {},
         "stages whose end is rendered as PNG key frames (e.g. perception, close_gripper, place, open_gripper_release; "
         "end: the trial's last state), under results/<name>/renders/trial_<N>/; empty: none");
  a.list("images", images, {"rgb", "depth", "segmentation", "segments"},
         "the images of a key frame: rgb (<k>_<stage>.png), depth (_depth.png: 16-bit, 0.1 mm units), segmentation "
         "(_seg.png: 0 scene, 1 robot, 2+k object k, 255 obstacle) and segments (_segments.png, for a human: camera mode "
         "with objects of no model, the robot's last view as perception cut it, each segment in a hue over its depth, and "
         "the fingers of the grasp it chose; none before the first perception)");
  a.value("video", video, "an MP4 of each rendered trial (H.264 through ffmpeg; simulated time played in real time)");
  a.value("fps", fps, {1, 100}, "1/s", "video frames per simulated second; must divide the 500 Hz control rate");
  a.list("trials", trials, {0, 1e7}, "the trials rendered; empty: every trial");
  a.value("camera", camera, "the scene's camera rendered");
  a.value("width", width, {16, 4096}, "px", "image width");
  a.value("height", height, {16, 4096}, "px", "image height");
  a.choice("egl", egl, {"auto", "device", "surfaceless"},
           "the offscreen OpenGL context: auto (a GPU's EGL device, else Mesa's surfaceless platform on the CPU), device, "
           "surfaceless. When none can be made the campaign runs without images and says why");
  a.value("previews", previews, "also colour previews of depth (_depth_view.png) and segmentation (_seg_view.png)");
}

bool RenderOptions::renders(uint64_t t) const {
  return enabled() && (trials.empty() || std::find(trials.begin(), trials.end(), static_cast<int64_t>(t)) != trials.end());
}

/// Forwards to the hardware, calling back before each control period and after it.
class TrialRenders::Tap : public ForwardingHardware {
 public:
  Tap(Hardware& inner, TrialRenders& owner, std::function<void()> before) : ForwardingHardware(inner), owner_(owner), before_(std::move(before)) {}
  void step() override {
    if (before_) before_();
    in_.step();
    owner_.afterStep();
  }

 private:
  TrialRenders& owner_;
  std::function<void()> before_;
};

TrialRenders::TrialRenders(Renderer& renderer, SimWorld& world, const RenderOptions& options, std::string dir,
                           const std::string& file)
    : renderer_(renderer), world_(world), options_(options), dir_(std::move(dir)) {
  camera_ = renderer_.camera(world_, options_.camera, options_.width, options_.height, file);
  for (const std::string& k : options_.images)
    kinds_ |= k == "rgb" ? kRgb : k == "depth" ? kDepth : k == "segmentation" ? kSegmentation : 0u;
  segments_ = std::find(options_.images.begin(), options_.images.end(), "segments") != options_.images.end();
  createDirectories(dir_);
  if (options_.video) {
    const double frames_per_period = options_.fps * kControlPeriod;
    steps_per_frame_ = std::max(1, static_cast<int>(std::lround(1.0 / frames_per_period)));
    video_ = std::make_unique<VideoWriter>((std::filesystem::path(dir_) / "trial.mp4").string(), options_.width,
                                           options_.height, options_.fps);
    video_->add(renderer_.render(world_, camera_, kRgb));
  }
}

TrialRenders::~TrialRenders() = default;

Hardware& TrialRenders::wrap(Hardware& inner, std::function<void()> before_step) {
  tap_ = std::make_unique<Tap>(inner, *this, std::move(before_step));
  return *tap_;
}

void TrialRenders::afterStep() {
  ++steps_;
  if (video_ && steps_ % steps_per_frame_ == 0) video_->add(renderer_.render(world_, camera_, kRgb));
}

void TrialRenders::stageEnded(const std::string& stage) {
  if (std::find(options_.keyframes.begin(), options_.keyframes.end(), stage) != options_.keyframes.end()) keyFrame(stage);
}

void TrialRenders::setSegments(std::shared_ptr<const Frame> view, std::shared_ptr<const std::vector<uint16_t>> segment,
                               std::vector<WorldBox> fingers) {
  view_ = std::move(view), segment_ = std::move(segment), fingers_ = std::move(fingers);
}

void TrialRenders::keyFrame(const std::string& label) {
  const bool segments = segments_ && view_ && segment_;
  if (!kinds_ && !segments) return;
  const Frame f = kinds_ ? renderer_.render(world_, camera_, kinds_) : Frame{};
  char prefix[16];
  std::snprintf(prefix, sizeof prefix, "%02d_", ++count_);
  const std::string base = prefix + label;
  auto path = [&](const std::string& suffix) {
    files_.push_back(base + suffix);
    return (std::filesystem::path(dir_) / (base + suffix)).string();
  };
  if (kinds_ & kRgb) writeRgbPng(path(".png"), f);
  if (kinds_ & kDepth) {
    writeDepthPng(path("_depth.png"), f);
    if (options_.previews) writeDepthPreview(path("_depth_view.png"), f);
  }
  if (kinds_ & kSegmentation) {
    writeSegmentationPng(path("_seg.png"), f);
    if (options_.previews) writeSegmentationPreview(path("_seg_view.png"), f);
  }
  if (segments) writeSegmentsPicture(path("_segments.png"), *view_, *segment_, fingers_);
}

std::vector<std::string> TrialRenders::finish() {
  if (std::find(options_.keyframes.begin(), options_.keyframes.end(), "end") != options_.keyframes.end()) keyFrame("end");
  if (video_) {
    video_->close();
    files_.push_back("trial.mp4");
    video_.reset();
  }
  return files_;
}

}  // namespace mm
