// A campaign's worker processes (`minimanip worker`, started by the supervisor, not by people):
// the line protocol, starting one, the watchdog's patience, and one trial run in a worker.
// Internal to src/campaign/.
//
// Supervisor -> worker, one line per trial: "RUN <trial> <attempt>"; end of input: exit.
// Worker -> supervisor: "READY <fingerprint digest>" once loaded, then per trial its trials.jsonl
// line, or "ERROR <message>" before it exits on an internal error, or "OUTPUT <path>\t<cause>"
// when it cannot write its results (a full disk): the supervisor stops the campaign with that.
#pragma once
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "campaign/experiment.h"
#include "campaign/record.h"
#include "campaign/trial.h"
#include "core/child_process.h"

namespace mm {

class SimWorld;

struct WorkerProcess {
  pid_t pid = -1;
  int to = -1, from = -1;  ///< its stdin, its stdout
  std::string buffer;      ///< output not yet ending in a newline
  bool ready = false;
  bool busy = false;
  uint64_t trial = 0;
  int attempt = 0;
  std::chrono::steady_clock::time_point started;
  bool watchdog_killed = false;
  double watchdog_limit = 0;
  std::string error;  ///< its ERROR line, if any
};

/// Starts `binary` with `args`, its stdin and stdout as pipes to us (startChild: it dies with this
/// process, even by kill -9). Lines to it: sendLine.
WorkerProcess spawnWorker(const std::string& binary, const std::vector<std::string>& args);

/// The watchdog's patience: the configured limit, or 10x the median trial when that is more.
class Watchdog {
 public:
  explicit Watchdog(double floor) : floor_(floor) {}
  void finished(double seconds);
  double limit() const;

 private:
  static constexpr size_t kKeep = 1001;  // the median of the latest trials, in constant memory
  double floor_;
  std::vector<double> recent_;
  size_t next_ = 0;
};

/// Trial `trial` of the experiment: its objects spawned from the trial's scene stream, then its
/// tree run (nothing when the spawn failed: failure_kind spawn). Log paths relative to `out`.
TrialRecord runOneTrial(const Experiment& e, const RobotModel& robot, const Cell& cell, SimWorld& world, TrialRunner& runner,
                        uint64_t trial, const std::filesystem::path& out);

}  // namespace mm
