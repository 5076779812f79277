#include "render/image_io.h"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sys/statvfs.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "core/file_io.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

// OpenCV runs its parallel loops on TBB worker threads unless told otherwise. Library calls run in
// the calling thread here (docs/design/determinism.md); a worker thread alive at exit also crashed
// LeakSanitizer's end-of-process check now and then.
[[maybe_unused]] const int kOpenCvInCallingThread = (cv::setNumThreads(0), 0);

// Encoded in memory, then written whole by temp file + rename: a full disk is reported with its
// cause (OutputError) and leaves no half image.
void write(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> bytes;
  bool ok = false;
  try {
    ok = cv::imencode(".png", image, bytes);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot encode " + path + ": " + e.what());
  }
  if (!ok) throw std::runtime_error("cannot encode " + path + " as PNG");
  writeFileAtomically(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

void need(const Frame& f, bool present, const char* what) {
  if (!present) throw std::logic_error(std::string("frame of camera '") + f.camera.name + "' has no " + what);
}

}  // namespace

void writeRgbPng(const std::string& path, const Frame& f) {
  need(f, !f.rgb.empty(), "rgb");
  cv::Mat rgb(f.camera.height, f.camera.width, CV_8UC3, const_cast<uint8_t*>(f.rgb.data())), bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  write(path, bgr);
}

void writeDepthPng(const std::string& path, const Frame& f) {
  need(f, !f.depth.empty(), "depth");
  cv::Mat d(f.camera.height, f.camera.width, CV_16UC1);
  for (int r = 0; r < d.rows; ++r)
    for (int c = 0; c < d.cols; ++c) {
      const double z = f.depth[static_cast<size_t>(r) * static_cast<size_t>(d.cols) + static_cast<size_t>(c)];
      d.at<uint16_t>(r, c) = static_cast<uint16_t>(std::clamp(std::lround(z / kDepthPngScale), 0L, 65535L));
    }
  write(path, d);
}

std::vector<float> readDepthPng(const std::string& path, int* width, int* height) {
  const cv::Mat d = cv::imread(path, cv::IMREAD_ANYDEPTH);
  if (d.empty() || d.type() != CV_16UC1) throw std::runtime_error(path + ": not a 16-bit depth PNG");
  *width = d.cols;
  *height = d.rows;
  std::vector<float> z(static_cast<size_t>(d.rows) * static_cast<size_t>(d.cols));
  for (int r = 0; r < d.rows; ++r)
    for (int c = 0; c < d.cols; ++c)
      z[static_cast<size_t>(r) * static_cast<size_t>(d.cols) + static_cast<size_t>(c)] =
          static_cast<float>(d.at<uint16_t>(r, c) * kDepthPngScale);
  return z;
}

void writeSegmentationPng(const std::string& path, const Frame& f) {
  need(f, !f.segmentation.empty(), "segmentation");
  write(path, cv::Mat(f.camera.height, f.camera.width, CV_8UC1, const_cast<uint8_t*>(f.segmentation.data())));
}

void writeDepthPreview(const std::string& path, const Frame& f) {
  need(f, !f.depth.empty(), "depth");
  // Near to far over 0..255, histogram-equalized so that the few centimetres between a bin's floor
  // and the objects on it show as well as the metre down to the floor.
  float lo = 1e9f, hi = 0;
  for (float z : f.depth)
    if (z > 0) lo = std::min(lo, z), hi = std::max(hi, z);
  cv::Mat grey(f.camera.height, f.camera.width, CV_8UC1), equalized, colour;
  for (size_t i = 0; i < f.depth.size(); ++i) {
    const float z = f.depth[i];
    grey.data[i] = z > 0 && hi > lo ? static_cast<uint8_t>(std::lround(255.0 * (z - lo) / (hi - lo))) : 255;
  }
  cv::equalizeHist(grey, equalized);
  cv::applyColorMap(equalized, colour, cv::COLORMAP_TURBO);
  for (size_t i = 0; i < f.depth.size(); ++i)
    if (f.depth[i] <= 0) colour.at<cv::Vec3b>(static_cast<int>(i)) = cv::Vec3b(0, 0, 0);
  write(path, colour);
}

namespace {

// A label's colour (BGR): hues spaced by the golden angle, so neighbours' colours differ.
cv::Vec3b hueOf(int k) {
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(static_cast<int>(std::fmod(k * 137.5, 360.0) / 2), 220, 255)), out;
  cv::cvtColor(hsv, out, cv::COLOR_HSV2BGR);
  return out.at<cv::Vec3b>(0, 0);
}

}  // namespace

void writeSegmentsPicture(const std::string& path, const Frame& view, const std::vector<uint16_t>& segment,
                          const std::vector<WorldBox>& boxes) {
  need(view, !view.depth.empty(), "depth");
  const int w = view.camera.width, h = view.camera.height;
  if (view.depth.size() != static_cast<size_t>(w) * static_cast<size_t>(h) || segment.size() != view.depth.size())
    throw std::runtime_error(path + ": a depth and a segment label per pixel expected");
  // The depth, near light and far dark, over the range the segments span (the bin's few centimetres).
  float lo = 1e9f, hi = 0;
  for (size_t i = 0; i < segment.size(); ++i)
    if (segment[i] && view.depth[i] > 0) lo = std::min(lo, view.depth[i]), hi = std::max(hi, view.depth[i]);
  if (hi <= lo) lo = 0, hi = 1e9f;
  hi += 0.03f;  // the floor just below the lowest segment stays visible
  cv::Mat bgr(h, w, CV_8UC3);
  for (int i = 0; i < w * h; ++i) {
    const float z = view.depth[static_cast<size_t>(i)];
    const double shade = z > 0 ? 60 + 170 * std::clamp((hi - z) / (hi - lo), 0.0f, 1.0f) : 0;
    cv::Vec3b c(static_cast<uint8_t>(shade), static_cast<uint8_t>(shade), static_cast<uint8_t>(shade));
    const int k = segment[static_cast<size_t>(i)];
    if (k) {
      const cv::Vec3b hue = hueOf(k - 1);
      for (int ch = 0; ch < 3; ++ch) c[ch] = static_cast<uint8_t>(0.4 * c[ch] + 0.6 * hue[ch]);
      // Its outline: a pixel next to another label.
      const int u = i % w, v = i / w;
      const bool edge = (u > 0 && segment[static_cast<size_t>(i - 1)] != k) || (u + 1 < w && segment[static_cast<size_t>(i + 1)] != k) ||
                        (v > 0 && segment[static_cast<size_t>(i - w)] != k) || (v + 1 < h && segment[static_cast<size_t>(i + w)] != k);
      if (edge) c = cv::Vec3b(20, 20, 20);
    }
    bgr.at<cv::Vec3b>(i) = c;
  }
  // The boxes: the outline of each one's projected corners.
  const int thick = std::max(2, w / 400);
  for (const WorldBox& b : boxes) {
    std::vector<cv::Point2f> corners;
    for (int k = 0; k < 8; ++k) {
      const Vec3 p = b.T_world_box * Vec3(k & 1 ? b.half.x() : -b.half.x(), k & 2 ? b.half.y() : -b.half.y(), k & 4 ? b.half.z() : -b.half.z());
      const Vec3 px = view.camera.project(p);
      if (px.z() <= 0) continue;
      corners.emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()));
    }
    if (corners.size() < 3) continue;
    std::vector<cv::Point2f> hull;
    cv::convexHull(corners, hull);
    std::vector<cv::Point> outline;
    for (const cv::Point2f& p : hull) outline.emplace_back(cvRound(p.x), cvRound(p.y));
    cv::Mat filled = bgr.clone();
    cv::fillConvexPoly(filled, outline, cv::Scalar(255, 255, 255), cv::LINE_AA);
    cv::addWeighted(filled, 0.5, bgr, 0.5, 0, bgr);
    cv::polylines(bgr, outline, true, cv::Scalar(0, 0, 0), thick, cv::LINE_AA);
  }
  write(path, bgr);
}

void writeSegmentationPreview(const std::string& path, const Frame& f) {
  need(f, !f.segmentation.empty(), "segmentation");
  cv::Mat bgr(f.camera.height, f.camera.width, CV_8UC3);
  for (size_t i = 0; i < f.segmentation.size(); ++i) {
    const int label = f.segmentation[i];
    cv::Vec3b c;
    if (label == kSegmentScene) c = cv::Vec3b(60, 60, 60);
    else if (label == kSegmentRobot) c = cv::Vec3b(200, 200, 200);
    else if (label == kSegmentObstacle) c = cv::Vec3b(0, 0, 255);
    else
      c = hueOf(label - kSegmentObject0);  // objects in hues spaced by the golden angle
    bgr.at<cv::Vec3b>(static_cast<int>(i)) = c;
  }
  write(path, bgr);
}

bool VideoWriter::available(std::string* why) {
  FILE* p = popen("ffmpeg -hide_banner -loglevel error -encoders 2>/dev/null", "r");
  if (!p) {
    *why = "cannot start ffmpeg";
    return false;
  }
  std::string text;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) text.append(buf, n);
  const int status = pclose(p);
  if (status != 0) {
    *why = "ffmpeg is not installed (Debian package ffmpeg)";
    return false;
  }
  if (text.find("libx264") == std::string::npos) {
    *why = "ffmpeg has no libx264 encoder";
    return false;
  }
  return true;
}

VideoWriter::VideoWriter(std::string path, int width, int height, int fps)
    : path_(std::move(path)), width_(width), height_(height) {
  // yuv420p (even sizes) for players' sake; constant frame rate; the moov atom first (faststart).
  const std::string cmd = "ffmpeg -hide_banner -loglevel error -y -f rawvideo -pix_fmt rgb24 -s " + std::to_string(width) +
                          "x" + std::to_string(height) + " -r " + std::to_string(fps) +
                          " -i - -an -c:v libx264 -preset veryfast -crf 23 -pix_fmt yuv420p -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2'"
                          " -movflags +faststart '" + path_ + "'";
  pipe_ = popen(cmd.c_str(), "w");
  if (!pipe_) throw std::runtime_error("cannot start ffmpeg for " + path_);
}

VideoWriter::~VideoWriter() {
  if (pipe_) pclose(pipe_);
}

void VideoWriter::add(const Frame& f) {
  if (!pipe_ || failed_) return;
  if (f.camera.width != width_ || f.camera.height != height_ || f.rgb.empty())
    throw std::logic_error("video " + path_ + ": a frame of another size or without rgb");
  // A write to an ffmpeg that died fails (EPIPE; the campaign's processes ignore SIGPIPE): close() reports it.
  if (fwrite(f.rgb.data(), 1, f.rgb.size(), pipe_) != f.rgb.size()) failed_ = true;
  else ++frames_;
}

int VideoWriter::close() {
  if (!pipe_) return frames_;
  const int status = pclose(pipe_);
  pipe_ = nullptr;
  if (failed_ || status != 0) {
    // ffmpeg says why on stderr; a folder that cannot be written is the usual cause, and it is
    // the folder's, not the trial's: an OutputError stops the campaign with the path.
    struct statvfs fs {};
    const std::string dir = path_.substr(0, path_.find_last_of('/') + 1);
    std::string cause = "the video encoder (ffmpeg) exited with status " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : status);
    if (::statvfs(dir.empty() ? "." : dir.c_str(), &fs) == 0 && fs.f_bavail == 0) cause = errnoText(ENOSPC) + " (" + cause + ")";
    else if (::access(dir.empty() ? "." : dir.c_str(), W_OK) != 0) cause = errnoText(errno) + " (" + cause + ")";
    throw OutputError(path_, cause);
  }
  return frames_;
}

}  // namespace mm
