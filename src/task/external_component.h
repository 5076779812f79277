// An external component during trials: the user's program (a grasp detector in Python, on a GPU
// elsewhere), started once per worker and kept across its trials, asked over the process protocol
// (perception/external_protocol.h) for each view. A call writes the view's images to files (under
// /dev/shm when there is one), sends the request, and reads the answer under the wall-clock cap.
// Whatever the child does is a value of the call, never an exception: it answered; it answered with
// its own error; it crashed (its output ended); it hung past the cap; it answered something that is
// not the protocol (or in another frame than configured); it could not be started. After anything
// but an answer the child is ended and the next call starts a fresh one.
#pragma once
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "perception/external_protocol.h"
#include "task/task_options.h"
#include "task/trial_outcome.h"

namespace mm {

class ChildProcess;
struct Frame;

/// One call's result (recorded per call in the trial's record: ExternalCallRecord).
struct ExternalCall {
  /// answer, error (the child's own), crash, timeout, not_protocol, cannot_start, io_error (ours:
  /// the images could not be written)
  std::string result;
  std::string reason;         ///< for all but answer: what happened, for the trial's failure
  double write_seconds = 0;   ///< [s] wall: writing the images
  double answer_seconds = 0;  ///< [s] wall: the request sent until the answer read (the child's time and the pipe's)
  ExternalAnswer answer;      ///< result answer: in the world frame
  std::string line;           ///< results answer and error: the answer line as it came
  bool ok() const { return result == "answer"; }
};

class ExternalComponent {
 public:
  /// `stderr_log`: the child's stderr is appended there. Nothing is started until the first call.
  ExternalComponent(ExternalOptions options, std::filesystem::path stderr_log);
  ~ExternalComponent();
  ExternalComponent(const ExternalComponent&) = delete;
  ExternalComponent& operator=(const ExternalComponent&) = delete;

  /// A trial begins: request ids count from 1 again (a request is named by its trial and its id,
  /// so a trial's requests and answers do not depend on what its worker ran before).
  void beginTrial() { next_id_ = 1; }
  /// Asks for `request` (its id set here, its image paths filled in) on `frame`'s images: depth
  /// always, rgb when the frame has colour, labels when options.oracle and the frame has them.
  ExternalCall call(ExternalRequest& request, const Frame& frame);
  /// A replay of a recorded trial (`minimanip render`): from now on each call is answered, in
  /// order, by the trial's recorded calls (an answer line read again as it was read then; a failure
  /// as recorded), and no component is started. A call past the recorded ones is result
  /// not_recorded.
  void replay(std::vector<ExternalCallRecord> calls);
  const ExternalOptions& options() const { return options_; }
  /// Children started so far (the first, and one after each failed call that ended one).
  int starts() const { return starts_; }

 private:
  ExternalCall ask(ExternalRequest& request, const Frame& frame);
  ExternalCall answerFromRecord(ExternalRequest& request);
  /// Reads `line`, the answer to `request`, into out (result answer, error or not_protocol).
  bool readAnswer(const std::string& line, const ExternalRequest& request, ExternalCall& out);
  std::string stopChild();
  ExternalOptions options_;
  std::filesystem::path stderr_log_, image_dir_;
  std::unique_ptr<ChildProcess> child_;
  uint64_t next_id_ = 1;
  int starts_ = 0;
  bool replaying_ = false;
  std::vector<ExternalCallRecord> recorded_;
  size_t next_recorded_ = 0;
};

}  // namespace mm
