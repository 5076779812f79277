#include "task/external_component.h"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include "core/camera.h"
#include "core/child_process.h"
#include "core/error.h"
#include "core/file_io.h"

namespace mm {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

constexpr const char* kImageDirPrefix = "minimanip-external-";

// Folders that processes no longer running left behind (a worker killed by the watchdog: SIGKILL
// runs no destructor), named kImageDirPrefix + "<pid>-": removed. A folder whose pid runs again
// (reused) is left for a later sweep.
void removeOrphanImageDirs(const fs::path& base) {
  std::error_code ec;
  for (fs::directory_iterator it(base, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(kImageDirPrefix, 0) != 0) continue;
    char* rest = nullptr;
    const long pid = std::strtol(name.c_str() + std::strlen(kImageDirPrefix), &rest, 10);
    if (pid <= 0 || !rest || *rest != '-') continue;
    if (kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code ignored;
    fs::remove_all(it->path(), ignored);
  }
}

// A folder of this process's own for the images: under /dev/shm (memory) when there is one.
fs::path makeImageDir() {
  std::error_code ec;
  const fs::path shm = "/dev/shm";
  const fs::path base = fs::is_directory(shm, ec) && access(shm.c_str(), W_OK) == 0 ? shm : fs::temp_directory_path();
  removeOrphanImageDirs(base);
  std::string pattern = (base / (kImageDirPrefix + std::to_string(getpid()) + "-XXXXXX")).string();
  if (!mkdtemp(pattern.data())) throw OutputError(pattern, errnoText(errno));
  return pattern;
}

}  // namespace

ExternalComponent::ExternalComponent(ExternalOptions options, fs::path stderr_log)
    : options_(std::move(options)), stderr_log_(std::move(stderr_log)) {}

ExternalComponent::~ExternalComponent() {
  stopChild();
  if (!image_dir_.empty()) {
    std::error_code ec;
    fs::remove_all(image_dir_, ec);
  }
}

std::string ExternalComponent::stopChild() {
  if (!child_) return "";
  const std::string how = child_->stop(0.5);
  child_.reset();
  return how;
}

ExternalCall ExternalComponent::call(ExternalRequest& request, const Frame& frame) {
  if (replaying_) return answerFromRecord(request);
  // Our own side failing (the images cannot be written: a full /dev/shm; a pipe that cannot be
  // polled) is a value too: that perception fails with the reason, and the next call starts afresh.
  try {
    return ask(request, frame);
  } catch (const std::exception& e) {
    stopChild();
    ExternalCall out;
    out.result = "io_error";
    out.reason = std::string("the external component could not be asked: ") + e.what();
    return out;
  }
}

ExternalCall ExternalComponent::ask(ExternalRequest& request, const Frame& frame) {
  ExternalCall out;
  const CameraModel& cam = frame.camera;
  const size_t pixels = static_cast<size_t>(cam.width) * static_cast<size_t>(cam.height);
  // The images, as files the child reads (rewritten each call: a child reads them before answering).
  const auto t_write = Clock::now();
  if (image_dir_.empty()) image_dir_ = makeImageDir();
  const std::vector<size_t> shape{static_cast<size_t>(cam.height), static_cast<size_t>(cam.width)};
  request.depth = image_dir_ / "depth.npy";
  writeNpy(request.depth, "<f4", shape, frame.depth.data(), frame.depth.size() * sizeof(float));
  request.rgb.clear();
  if (frame.rgb.size() == 3 * pixels) {
    request.rgb = image_dir_ / "rgb.npy";
    writeNpy(request.rgb, "|u1", {shape[0], shape[1], 3}, frame.rgb.data(), frame.rgb.size());
  }
  request.labels.clear();
  request.oracle_segmentation = options_.oracle;
  if (options_.oracle && frame.segmentation.size() == pixels) {
    request.labels = image_dir_ / "labels.npy";
    writeNpy(request.labels, "|u1", shape, frame.segmentation.data(), frame.segmentation.size());
  }
  out.write_seconds = secondsSince(t_write);

  const auto t_answer = Clock::now();
  auto finish = [&](const char* result, std::string reason) {
    out.result = result;
    out.reason = std::move(reason);
    out.answer_seconds = secondsSince(t_answer);
    return out;
  };
  request.id = next_id_++;
  const std::string id = std::to_string(request.id);
  if (!child_) {
    try {
      child_ = std::make_unique<ChildProcess>(ChildSpec{options_.argv(), options_.cwd, stderr_log_});
      ++starts_;
    } catch (const std::runtime_error& e) {
      return finish("cannot_start", std::string("the external component: ") + e.what());
    }
  }
  if (!child_->send(requestLine(request))) {
    const std::string how = stopChild();
    return finish("crash", "the external component ended before request " + id + " (" + how + ")");
  }
  std::string line;
  switch (child_->readLine(line, options_.timeout)) {
    case ChildProcess::Read::kLine:
      break;
    case ChildProcess::Read::kEnd: {
      const std::string how = stopChild();
      return finish("crash", "the external component ended without answering request " + id + " (" + how + ")");
    }
    case ChildProcess::Read::kTimeout: {
      stopChild();
      char buf[160];
      std::snprintf(buf, sizeof buf, "the external component did not answer request %s within external.timeout (%g s): stopped",
                    id.c_str(), options_.timeout);
      return finish("timeout", buf);
    }
    case ChildProcess::Read::kTooLong:
      stopChild();
      return finish("not_protocol", "the external component's answer to request " + id + " is longer than 64 MiB");
  }
  if (!readAnswer(line, request, out)) stopChild();
  out.answer_seconds = secondsSince(t_answer);
  return out;
}

bool ExternalComponent::readAnswer(const std::string& line, const ExternalRequest& request, ExternalCall& out) {
  const std::string id = std::to_string(request.id);
  std::string why;
  out.answer = ExternalAnswer{};
  out.line.clear();
  if (!parseAnswer(line, request, out.answer, why)) {
    out.answer = ExternalAnswer{};
    out.result = "not_protocol";
    out.reason = "the external component's answer to request " + id + " is not the protocol: " + why;
    return false;
  }
  if (!out.answer.error.empty()) {
    out.result = "error";
    out.reason = "the external component found nothing: " + out.answer.error.substr(0, 300);
    out.line = line;
    return true;
  }
  ExternalFrame expected = ExternalFrame::kCamera;
  parseExternalFrame(options_.frame, expected);
  if (out.answer.frame != expected) {
    out.answer = ExternalAnswer{};
    out.result = "not_protocol";
    out.reason = "the external component answered request " + id + " in the " + (expected == ExternalFrame::kCamera ? "world" : "camera") +
                 " frame; external.frame is " + options_.frame;
    return false;
  }
  out.result = "answer";
  out.reason.clear();
  out.line = line;
  return true;
}

void ExternalComponent::replay(std::vector<ExternalCallRecord> calls) {
  stopChild();
  replaying_ = true;
  recorded_ = std::move(calls);
  next_recorded_ = 0;
}

ExternalCall ExternalComponent::answerFromRecord(ExternalRequest& request) {
  ExternalCall out;
  request.id = next_id_++;
  if (next_recorded_ >= recorded_.size()) {
    out.result = "not_recorded";
    out.reason = "a replay: the trial's record has no answer to request " + std::to_string(request.id) + " of the external component";
    return out;
  }
  const ExternalCallRecord& r = recorded_[next_recorded_++];
  if (r.result == "answer" || r.result == "error") {
    // The same request (the same trial's view, the same id) reads the recorded line as it was read.
    readAnswer(r.answer, request, out);
  } else {
    out.result = r.result;
    out.reason = r.reason;
  }
  out.write_seconds = r.write_seconds;
  out.answer_seconds = r.answer_seconds;
  return out;
}

}  // namespace mm
