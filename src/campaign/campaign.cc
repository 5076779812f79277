#include "campaign/campaign.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "campaign/record.h"
#include "campaign/stats.h"
#include "campaign/trial.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/folder_lock.h"
#include "core/utf8.h"
#include "planning/planner.h"
#include "render/gl_context.h"
#include "render/renderer.h"
#include "sim/hardware.h"
#include "sim/mjcf_robot.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

std::string fixed(double v, int precision) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(precision) << v;
  return o.str();
}

TrialRecord makeRecord(const Experiment& e, uint64_t trial, const SpawnResult& spawn, TrialOutcome o, const std::string& bt_log) {
  TrialRecord r;
  r.trial = trial;
  r.seed = e.seed;
  r.hardware = e.hardware;
  r.objects_in_bin = spawn.ok ? static_cast<int>(spawn.active.size()) : 0;  // a failed spawn put no object in play
  r.spawn_attempts = spawn.attempts;
  r.bt_log = bt_log;
  r.o = std::move(o);
  return r;
}

/// Empty but for a lock file a finished writer left.
bool isEmptyFolder(const fs::path& dir) {
  for (const auto& f : fs::directory_iterator(dir))
    if (f.path().filename() != FolderLock::kFileName) return false;
  return true;
}

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

std::string localDateTime() {
  const std::time_t now = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", std::localtime(&now));
  return buf;
}

std::string hostName() {
  char buf[256] = "";
  gethostname(buf, sizeof buf - 1);
  return buf;
}

void fillEnvironment(CampaignSummary& s) {
  s.minimanip = MINIMANIP_VERSION;
  s.mujoco = mujocoVersion();
  s.ompl = omplVersion();
  s.compiler = std::string("gcc ") + __VERSION__;
  s.cpu = cpuModel();
  s.cores = std::thread::hardware_concurrency();
  s.host = hostName();
}

}  // namespace

std::string summaryTable(const CampaignSummary& s) {
  const long n = s.trials;
  std::ostringstream t;
  t << std::fixed;
  const std::string rule(64, '=');
  t << rule << "\n  Bin-Picking Performance Report: " << s.experiment << " (" << s.hardware << ", seed " << s.seed << ")\n" << rule << "\n";
  t << std::setprecision(1);
  t << "  Trials:            " << n << "\n";
  t << "  First-pass Yield:  " << 100.0 * s.first_pass_yield << "%  [95% CI " << 100 * s.first_pass_ci95[0] << ", "
    << 100 * s.first_pass_ci95[1] << "]\n";
  t << "  Overall Yield:     " << 100.0 * s.overall_yield << "%  [95% CI " << 100 * s.overall_ci95[0] << ", " << 100 * s.overall_ci95[1]
    << "]\n";
  t << "  Recovery Rate:     "
    << (s.recoveries_needed ? fixed(100.0 * s.recovery_rate, 1) + "% (" + std::to_string(s.recovered) + " of " +
                                  std::to_string(s.recoveries_needed) + " trials that needed one)"
                            : std::string("n/a (no recovery needed)"))
    << "\n";
  t << std::string(64, '-') << "\n" << std::setprecision(2);
  t << "  Mean Cycle Time:   " << s.cycle_mean << " +/- " << s.cycle_std << " s   (max " << s.cycle_max << " s)\n";
  t << "  Throughput:        " << std::setprecision(0) << s.throughput_per_hour << " picks/h (objects placed per hour, all trials' time)\n";
  t << std::string(64, '-') << "\n  Time Breakdown (mean over successes):\n";
  const std::pair<const char*, const char*> rows[] = {
      {"perception_time", "Perception    (compute)"}, {"plan_pick_time", "Plan Pick     (compute)"},
      {"execute_pick_time", "Exec Pick     (sim)"},   {"plan_place_time", "Plan Place    (compute)"},
      {"execute_place_time", "Exec Place    (sim)"},   {"return_home_time", "Return Home   (plan + sim)"}};
  for (const auto& [key, label] : rows)
    t << "    " << std::left << std::setw(28) << label << std::right << std::setw(9) << std::setprecision(1)
      << 1000 * (s.breakdown.count(key) ? s.breakdown.at(key) : 0.0) << " ms\n";
  t << std::string(64, '-') << "\n" << std::setprecision(2);
  t << "  Place Error:       " << s.place_mm_mean << " mm (mean), " << s.place_mm_max << " mm (max); " << s.orient_deg_mean
    << " deg (mean)\n";
  t << "  In-hand Slip:      " << s.slip_mm_mean << " mm (mean), " << s.slip_mm_max << " mm (max), grasp to release\n";
  t << "  Grasp Deviation:   " << s.grasp_dev_mm_mean << " mm (mean), " << s.grasp_dev_mm_max << " mm (max); " << s.side_grasps << " of "
    << s.side_grasps + s.top_down_grasps << " picks from the side\n";
  if (s.detections > 0) {
    t << "  Camera Pose Error: centre " << s.det_centre_mm_mean << " mm (mean), " << s.det_centre_mm_max << " mm (max); rotation "
      << s.det_rotation_deg_mean << " deg (mean), " << s.det_rotation_deg_max << " deg (max); MSSD " << s.det_mssd_mm_mean
      << " mm (mean)\n";
    t << "  Detections:        " << s.detections << " (" << s.false_detections << " false, " << s.missed_detections << " objects missed)\n";
  }
  t << "  Collisions:        " << s.collision_events << " events in " << n << " trials\n";
  t << "  Objects placed:    " << s.objects_placed << " (" << s.objects_left_in_bin << " left in bins; " << s.bins_cleared << " of "
    << n << " bins empty" << (s.spawn_failures ? "; " + std::to_string(s.spawn_failures) + " spawns failed" : std::string()) << ")\n";
  if (s.objects_spawned > 0)
    t << "  Object Yield:      " << std::setprecision(1) << 100 * s.object_yield << "%  [95% CI " << 100 * s.object_yield_ci95.at(0)
      << ", " << 100 * s.object_yield_ci95.at(1) << "]; first-pass " << 100 * s.object_first_pass_yield << "% [95% CI "
      << 100 * s.object_first_pass_ci95.at(0) << ", " << 100 * s.object_first_pass_ci95.at(1) << "]\n";
  t << "  Max Tracking Err:  " << std::setprecision(4) << s.max_tracking_error << " rad\n";
  if (!s.faults.empty()) {
    t << std::string(64, '-') << "\n  Faults: injected, detected; recovered of those judged (unrecoverable kinds:\n"
      << "  correctly given up), Wilson 95% interval; MTTR (onset to the stage's success)\n";
    for (const FaultStats& f : s.faults) {
      t << "    " << std::left << std::setw(22) << f.kind << std::right << std::setw(4) << f.injected << " inj, " << std::setw(3)
        << f.detected << " det, ";
      const long good = f.recoverable ? f.recovered : f.given_up;
      if (f.recovery >= 0)
        t << (f.recoverable ? "recovered " : "given up ") << good << "/" << good + f.unrecovered << " = " << std::setprecision(1)
          << 100 * f.recovery << "% [" << 100 * f.ci95[0] << ", " << 100 * f.ci95[1] << "]";
      else
        t << "none judged";
      if (f.mttr_mean >= 0) t << std::setprecision(2) << ", MTTR " << f.mttr_mean << " s";
      t << "\n";
    }
    t << std::setprecision(1) << "  MTBF:              " << (s.mtbf >= 0 ? fixed(s.mtbf, 1) + " s (simulated)" : std::string("no unrecovered failure"))
      << "; protective stops: " << s.protective_stops << "\n";
  }
  if (!s.failure_stages.empty()) {
    t << std::string(64, '-') << "\n  Failure Analysis:\n";
    for (const auto& [stage, count] : s.failure_stages) t << "    " << stage << ": " << count << "\n";
  }
  t << rule << "\n";
  return t.str();
}

namespace {

class Progress {
 public:
  /// `total` trials in all, `before` of them done by an earlier run (resume).
  Progress(const std::string& mode, long total, long before)
      : total_(total), before_(before), t0_(std::chrono::steady_clock::now()) {
    bar_ = mode == "bar" || (mode == "auto" && isatty(STDERR_FILENO));
    quiet_ = mode == "none";
  }
  void update(long done, long ok, uint64_t trial, const TrialOutcome& o) {
    if (quiet_) return;
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    const long now = done - before_;  // this run's pace
    const double eta = now > 0 ? el / now * (total_ - done) : 0;
    char buf[256];
    if (bar_) {
      const int w = 30, fill = static_cast<int>(w * done / std::max(total_, 1L));
      std::snprintf(buf, sizeof buf, "\r[%s%s] %ld/%ld  yield %.1f%%  ETA %.0fs ", std::string(fill, '#').c_str(),
                    std::string(w - fill, '.').c_str(), done, total_, 100.0 * ok / std::max(done, 1L), eta);
      std::cerr << buf << (done == total_ ? "\n" : "") << std::flush;
    } else {
      std::snprintf(buf, sizeof buf, "trial %lu: %s%s%s  cycle %.2fs  [%ld/%ld, yield %.1f%%, ETA %.0fs]\n",
                    static_cast<unsigned long>(trial), o.success ? "ok" : "FAILED at ", o.failure_stage.c_str(),
                    o.success ? "" : (" (" + o.failure_reason + ")").c_str(), o.total_time, done, total_,
                    100.0 * ok / std::max(done, 1L), eta);
      std::cerr << buf << std::flush;
    }
  }

 private:
  long total_, before_;
  std::chrono::steady_clock::time_point t0_;
  bool bar_ = false, quiet_ = false;
};


// ---- what a campaign's results depend on: the resume check ------------------------------------

using json = nlohmann::json;

// FNV-1a, 64 bits: a change detector for input files (not a cryptographic hash).
std::string digest(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (const unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

std::string fileDigest(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return digest(s.str());
}

// Keys that change how a campaign runs, not what its trials do.
bool runOnlyKey(const std::string& key) {
  // Rendering reads the world and never changes it: a campaign resumed with other renders is the same campaign.
  return key == "trials" || key == "only" || key == "shard" || key == "jobs" || key == "progress" || key == "watchdog" ||
         key.rfind("render.", 0) == 0;
}

/// Every key's value as used; the robot, its gripper (the arm's default too), scene and tree by
/// their files' contents.
json fingerprintOf(const Experiment& e) {
  json f = json::object();
  for (const ParamDecl& d : e.params.decls()) {
    if (runOnlyKey(d.key)) continue;
    f[d.key] = e.params.getString(d.key);
  }
  const RobotSpec robot = loadAnyRobotSpec(e.robot_path, e.gripper_path == "default" ? "" : e.gripper_path);
  f["robot"] = "contents " + fileDigest(e.robot_path) + (robot.sidecar.empty() ? "" : " " + fileDigest(robot.sidecar));
  f["gripper"] = "contents " + fileDigest(robot.gripper.file);
  f["scene"] = "contents " + fileDigest(e.scene_path);
  f["tree"] = "contents " + fileDigest(e.tree_path);
  if (e.perception.extrinsics != "simulator") f["perception.extrinsics"] = "contents " + fileDigest(e.perception.extrinsics);
  return f;
}

/// What differs between the campaign in a results folder (`there`) and this one, in words.
std::string differences(const json& there, const json& here, const std::string& there_name = "there",
                        const std::string& here_name = "here") {
  std::string said;
  int n = 0;
  std::set<std::string> keys;
  for (const auto& [k, v] : there.items()) keys.insert(k);
  for (const auto& [k, v] : here.items()) keys.insert(k);
  for (const std::string& k : keys) {
    const std::string a = there.contains(k) ? there[k].get<std::string>() : "(absent)";
    const std::string b = here.contains(k) ? here[k].get<std::string>() : "(absent)";
    if (a == b) continue;
    if (n++ == 8) {
      said += "; ...";
      break;
    }
    said += (said.empty() ? "" : "; ") +
            (a.rfind("contents ", 0) == 0 ? k + " file contents differ" : k + " is " + a + " " + there_name + ", " + b + " " + here_name);
  }
  return said;
}

struct ResumeState {
  bool resumed = false;
  std::string date;               ///< the campaign's first start (the .db3 files' session date)
  std::string first_command;      ///< the command that started it
  long trials = 0;                ///< the campaign's trial count (the largest asked for)
  std::vector<char> done;         ///< by trial index
  long done_count = 0, ok_count = 0, dropped_lines = 0;
  std::string meta;               ///< campaign.json's text for this run (written when the run does anything)
};

/// Prepares `out` for the campaign: a new one, or the resumption of the same campaign (everything
/// but the run-only keys equal). Throws InputError before anything is written when the folder holds
/// another campaign's results. On resume, trials.jsonl keeps its complete records but those of
/// crashed or hung trials (run again) and loses a half-written last line.
ResumeState prepareResults(const Experiment& e, const fs::path& out, const json& fingerprint, const std::string& command,
                           const std::function<bool(uint64_t)>& will_run) {
  ResumeState st;
  const fs::path meta = out / "campaign.json", jsonl_path = out / "trials.jsonl";
  if (fs::exists(out / "sweep.json"))
    throw InputError(out.string(), "holds a sweep (sweep.json): a campaign of one cell goes in its own --out, or run the sweep again");
  if (fs::exists(meta)) {
    json there;
    try {
      there = json::parse(std::ifstream(meta));
    } catch (const std::exception& ex) {
      throw InputError(meta.string(), std::string("not a campaign record (") + ex.what() + "); remove the folder to start over");
    }
    const std::string diff = differences(there.value("fingerprint", json::object()), fingerprint);
    if (!diff.empty())
      throw InputError(meta.string(), "these results come from another configuration: " + diff +
                                          ". Resuming needs the same one (the trial count aside): use another --out, "
                                          "or remove the folder to start over");
    const std::string shard_there = there.value("shard", std::string("0/1"));
    if (shard_there != e.shard)
      throw InputError(meta.string(), "these results are shard " + shard_there + " of the campaign, this run is shard " + e.shard +
                                          ": use the shard's own folder");
    st.resumed = true;
    st.date = there.value("date", localDateTime());
    st.first_command = there.value("command", command);
    st.trials = std::max<long>(st.trials, there.value("trials", 0L));
  } else if (fs::exists(jsonl_path) || fs::exists(out / "summary.json")) {
    throw InputError(out.string(), "holds results but no campaign.json (not made by this version): remove it or use another --out");
  }
  createDirectories(out);
  if (e.bt_log != "none") createDirectories(out / "bt");
  if (fs::exists(out / "bt"))
    for (const auto& f : fs::directory_iterator(out / "bt"))
      if (f.path().extension() == ".tmp") fs::remove(f.path());  // a worker killed mid-write
  st.done.assign(static_cast<size_t>(e.trials), 0);
  if (st.resumed && fs::exists(jsonl_path)) {
    // Keep the complete, finished records. Read once to judge; rewrite (temp file + rename) only
    // when a line must go, so a resume with nothing to drop needs no room for a copy.
    std::vector<long> drop;  // line numbers
    {
      std::ifstream in(jsonl_path, std::ios::binary);
      std::string line;
      long number = 0;
      while (std::getline(in, line)) {
        ++number;
        if (in.eof()) {  // no newline: the supervisor died while writing it
          drop.push_back(number);
          break;
        }
        const TrialRecord r = fromJsonLine(line, jsonl_path.string() + ":" + std::to_string(number));
        if ((r.o.failure_kind == FailureKind::kCrash || r.o.failure_kind == FailureKind::kHang) && will_run(r.trial)) {
          drop.push_back(number);  // run again
          continue;
        }
        if (r.trial >= st.done.size()) st.done.resize(r.trial + 1, 0);
        if (st.done[r.trial])
          throw InputError(jsonl_path.string() + ":" + std::to_string(number), "trial " + std::to_string(r.trial) + " is recorded twice");
        st.done[r.trial] = 1;
        if (will_run(r.trial)) ++st.done_count, st.ok_count += r.o.success;  // this run's part, for the progress
      }
    }
    st.dropped_lines = static_cast<long>(drop.size());
    if (!drop.empty()) {
      const fs::path tmp = out / "trials.jsonl.tmp";
      try {
        AppendFile kept(tmp);
        std::ifstream in(jsonl_path, std::ios::binary);
        std::string line, chunk;
        long number = 0;
        size_t next_drop = 0;
        while (std::getline(in, line)) {
          ++number;
          if (next_drop < drop.size() && drop[next_drop] == number) {
            ++next_drop;
            continue;
          }
          chunk += line;
          chunk += '\n';
          if (chunk.size() > (1u << 20)) kept.append(chunk), chunk.clear();
        }
        kept.append(chunk);
        kept.close();
        if (::rename(tmp.c_str(), jsonl_path.c_str()) != 0) throw OutputError(jsonl_path.string(), errnoText(errno));
      } catch (...) {
        fs::remove(tmp);  // never left behind
        throw;
      }
    }
  } else if (!st.resumed) {
    st.date = localDateTime();
    st.first_command = command;
  }
  st.trials = std::max<long>(st.trials, static_cast<long>(e.trials));
  // How to load this experiment again (minimanip render replays a trial from it).
  const json replay = {{"experiment", fs::absolute(e.file).lexically_normal().string()},
                       {"sets", e.sets},
                       {"cwd", fs::current_path().string()}};
  st.meta = json{{"schema", 1},      {"date", st.date},           {"command", st.first_command}, {"trials", st.trials},
                 {"shard", e.shard}, {"fingerprint", fingerprint}, {"replay", replay}}
                .dump(2, ' ', false, json::error_handler_t::replace) +
            "\n";
  return st;
}

// ---- worker processes ------------------------------------------------------------------------

// Supervisor -> worker, one line per trial: "RUN <trial> <attempt>"; end of input: exit.
// Worker -> supervisor: "READY <fingerprint digest>" once loaded, then per trial its trials.jsonl
// line, or "ERROR <message>" before it exits on an internal error, or "OUTPUT <path>\t<cause>"
// when it cannot write its results (a full disk): the supervisor stops the campaign with that.

void testFault(const Experiment& e, uint64_t trial, int attempt) {
  auto has = [&](const std::vector<int64_t>& v) { return std::find(v.begin(), v.end(), static_cast<int64_t>(trial)) != v.end(); };
  if (has(e.test_faults.segfault) || (attempt == 1 && has(e.test_faults.segfault_once))) {
    volatile int* null = nullptr;
    *null = 1;  // a real segmentation fault
  }
  if (has(e.test_faults.hang))
    for (;;) pause();
}

TrialRecord runOneTrial(const Experiment& e, const RobotModel& robot, const Cell& cell, SimWorld& world, TrialRunner& runner,
                        uint64_t trial, const fs::path& out) {
  Rng rng_scene = Rng::stream(e.seed, trial, Purpose::kScene);
  const SpawnResult spawn = spawnObjects(world, robot, cell.T_world_bin, cell.bin_half, rng_scene, cell.spawn);
  TrialOutcome o;
  std::string bt_log;
  if (!spawn.ok) {
    o.failure_stage = "spawn";
    o.failure_kind = FailureKind::kSpawn;
    o.failure_reason = spawn.reason;
  } else {
    auto hw = e.hardware == "mock" ? makeMockHardware(world, robot, spawn.active) : makeMujocoHardware(world, robot, spawn.active);
    o = runner.run(*hw, world, trial, bt_log);
  }
  return makeRecord(e, trial, spawn, std::move(o), bt_log.empty() ? "" : fs::relative(bt_log, out).string());
}

std::string signalText(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  return "signal " + std::to_string(sig) + (abbrev ? std::string(" (SIG") + abbrev + ")" : "");
}

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

WorkerProcess spawnWorker(const std::string& binary, const std::vector<std::string>& args) {
  int to[2], from[2];
  if (pipe2(to, O_CLOEXEC) != 0 || pipe2(from, O_CLOEXEC) != 0) throw std::runtime_error("pipe: " + std::string(std::strerror(errno)));
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(binary.c_str()));
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork: " + std::string(std::strerror(errno)));
  if (pid == 0) {
    // The child: async-signal-safe calls only until exec.
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // dies with the supervisor, even by kill -9
    if (getppid() != parent) _exit(1);
    signal(SIGPIPE, SIG_DFL);
    dup2(to[0], STDIN_FILENO);
    dup2(from[1], STDOUT_FILENO);
    execv(binary.c_str(), argv.data());
    _exit(127);
  }
  close(to[0]);
  close(from[1]);
  WorkerProcess w;
  w.pid = pid;
  w.to = to[1];
  w.from = from[0];
  return w;
}

bool sendLine(int fd, const std::string& line) {
  const std::string s = line + "\n";
  size_t off = 0;
  while (off < s.size()) {
    const ssize_t n = write(fd, s.data() + off, s.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;  // the worker is gone (EPIPE): its end is seen on its output
    off += static_cast<size_t>(n);
  }
  return true;
}

/// The watchdog's patience: the configured limit, or 10x the median trial when that is more.
class Watchdog {
 public:
  explicit Watchdog(double floor) : floor_(floor) {}
  void finished(double seconds) {
    if (recent_.size() < kKeep) recent_.push_back(seconds);
    else recent_[next_++ % kKeep] = seconds;
  }
  double limit() const {
    if (recent_.empty()) return floor_;
    std::vector<double> v = recent_;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return std::max(floor_, 10.0 * v[v.size() / 2]);
  }

 private:
  static constexpr size_t kKeep = 1001;  // the median of the latest trials, in constant memory
  double floor_;
  std::vector<double> recent_;
  size_t next_ = 0;
};

}  // namespace

int runWorker(const Experiment& e, const std::string& out_dir) {
  // Our protocol owns the real stdout; anything else printed goes to stderr.
  const int protocol = dup(STDOUT_FILENO);
  dup2(STDERR_FILENO, STDOUT_FILENO);
  signal(SIGPIPE, SIG_IGN);  // a write to a gone supervisor fails instead
  FILE* to_supervisor = fdopen(protocol, "w");
  if (!to_supervisor) return 1;
  const fs::path out(out_dir);
  const RobotModel robot = loadExperimentRobot(e);
  auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);
  const bt::TreeDocument tree = loadTree(e);
  const json meta = json::parse(std::ifstream(out / "campaign.json"));
  TrialRunner runner(e, cell, tree, (out / "bt").string(), meta.at("date").get<std::string>());
  const RenderSetup renders = setUpRendering(e);
  runner.setRenderer(renders.renderer.get(), (out / "renders").string(), renders.options);
  std::fprintf(to_supervisor, "READY %s\n", digest(fingerprintOf(e).dump()).c_str());
  std::fflush(to_supervisor);
  char line[128];
  while (std::fgets(line, sizeof line, stdin)) {
    unsigned long trial = 0;
    int attempt = 0;
    if (std::sscanf(line, "RUN %lu %d", &trial, &attempt) != 2) return 1;
    testFault(e, trial, attempt);
    try {
      TrialRecord r = runOneTrial(e, robot, cell, *world, runner, trial, out);
      r.attempts = attempt;
      const std::string text = toJsonLine(r);
      std::fputs(text.c_str(), to_supervisor);
      std::fputc('\n', to_supervisor);
    } catch (const OutputError& ex) {
      // Not the trial's doing: the supervisor stops the campaign and names the path and cause.
      std::string path = ex.path(), cause = ex.cause();
      for (std::string* t : {&path, &cause}) std::replace_if(t->begin(), t->end(), [](char c) { return c == '\n' || c == '\t'; }, ' ');
      std::fprintf(to_supervisor, "OUTPUT %s\t%s\n", path.c_str(), cause.c_str());
      std::fflush(to_supervisor);
      return 3;
    } catch (const std::exception& ex) {
      std::string what = ex.what();
      std::replace(what.begin(), what.end(), '\n', ' ');
      std::fprintf(to_supervisor, "ERROR %s\n", what.c_str());
      std::fflush(to_supervisor);
      return 1;
    }
    if (std::fflush(to_supervisor) != 0) return 1;
  }
  return 0;
}

void checkCampaignInput(const Experiment& e) {
  // The text files the experiment names: UTF-8, checked where they enter (names in them reach
  // the records). The YAML experiment itself was checked as it was read.
  {
    const RobotSpec spec = loadAnyRobotSpec(e.robot_path, e.gripper_path == "default" ? "" : e.gripper_path);
    fs::path catalogue = e.spawn.catalogue;  // as SpawnOptions::resolve finds it
    if (catalogue.is_relative()) catalogue = fs::path(MINIMANIP_SOURCE_DIR) / catalogue;
    for (const std::string& f : {e.robot_path, spec.sidecar, spec.gripper.file, e.scene_path, e.tree_path, catalogue.string(),
                                 e.perception.extrinsics == "simulator" ? std::string() : e.perception.extrinsics}) {
      if (f.empty() || !fs::is_regular_file(f)) continue;
      std::ifstream in(f, std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      requireUtf8File(text.str(), f);
    }
  }
  const RobotModel robot = loadExperimentRobot(e);
  const auto world = loadWorld(e, robot);
  makeCell(e, robot, *world);
  loadTree(e);
  // The cameras named must exist; camera perception cannot run without a renderer.
  if (e.perception.mode == PerceptionMode::kCamera || e.render.enabled()) {
    std::string why;
    const auto renderer = Renderer::create(e.render.egl, &why);
    if (!renderer && e.perception.mode == PerceptionMode::kCamera)
      throw InputError(e.file, "perception.mode camera needs an offscreen OpenGL context, and none can be made here: " + why);
    if (renderer && e.perception.mode == PerceptionMode::kCamera)
      renderer->camera(*world, e.perception.camera, 64, 48, e.file, "perception.camera");
    if (renderer && e.render.enabled()) renderer->camera(*world, e.render.camera, 64, 48, e.file);
  }
}

std::string runCampaign(const Experiment& e, const CampaignOptions& co) {
  // Everything that can be bad input is loaded and checked before anything is written.
  checkCampaignInput(e);
  const json fingerprint = fingerprintOf(e);
  const std::string expected_digest = digest(fingerprint.dump());
  const fs::path out(co.out_dir);
  // This run's trials: `only` (each once) or all, within the shard.
  std::vector<uint64_t> wanted;
  for (int64_t t : e.only) wanted.push_back(static_cast<uint64_t>(t));
  if (wanted.empty())
    for (int64_t t = 0; t < e.trials; ++t) wanted.push_back(static_cast<uint64_t>(t));
  wanted.erase(std::remove_if(wanted.begin(), wanted.end(),
                              [&](uint64_t t) { return static_cast<int>(t % e.shard_count) != e.shard_index; }),
               wanted.end());
  std::sort(wanted.begin(), wanted.end());
  wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
  // One supervisor per folder: a second one (or a merge, a sweep) refuses, naming the first.
  std::string took_over;
  const FolderLock lock(out, "minimanip run", &took_over);
  if (!took_over.empty() && e.progress != "none") std::cerr << "note: " << took_over << "\n";
  ResumeState st = prepareResults(e, out, fingerprint, co.command_line,
                                  [&](uint64_t t) { return std::binary_search(wanted.begin(), wanted.end(), t); });

  std::deque<std::pair<uint64_t, int>> queue;  // trial, attempt
  for (uint64_t t : wanted)
    if (t >= st.done.size() || !st.done[t]) queue.emplace_back(t, 1);
  const long before = static_cast<long>(wanted.size() - queue.size());
  const long run_now = static_cast<long>(queue.size());
  // A resume with nothing to do writes nothing (not even the record of how it was called).
  const bool writes = run_now > 0 || st.dropped_lines > 0 || !fs::exists(out / "campaign.json") || !fs::exists(out / "summary.json");
  if (writes) {
    writeFileIfChanged(out / "campaign.json", st.meta);
    writeFileIfChanged(out / "config.resolved.yaml", "# " + co.command_line + "\n" + e.params.toYaml());
  }

  const std::string binary = co.worker_binary.empty() ? fs::read_symlink("/proc/self/exe").string() : co.worker_binary;
  std::vector<std::string> args = {"worker", e.file, "--out", out.string()};
  for (const std::string& s : e.sets) args.insert(args.end(), {"--set", s});

  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  struct sigaction old_pipe {};
  sigaction(SIGPIPE, &ignore, &old_pipe);  // a worker that died is seen on its output, not by a signal

  AppendFile jsonl;
  if (run_now > 0 || !fs::exists(out / "trials.jsonl")) jsonl = AppendFile(out / "trials.jsonl");
  Progress progress(e.progress, before + run_now, before);
  long done = before, ok = st.ok_count;
  Watchdog watchdog(e.watchdog);
  std::vector<WorkerProcess> workers(static_cast<size_t>(std::max(1, e.jobs)));
  const auto t0 = std::chrono::steady_clock::now();
  std::string fatal;
  std::pair<std::string, std::string> output_error;  // a worker could not write: path, cause
  int startup_failures = 0;  // workers in a row that ended before they were ready

  auto record = [&](const std::string& line) { jsonl.appendLine(line); };
  auto finishWorker = [&](WorkerProcess& w) {
    close(w.to);
    close(w.from);
    int status = 0;
    while (waitpid(w.pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (w.busy) {
      std::string how;
      if (w.watchdog_killed)
        how = "stopped by the watchdog after " + fixed(w.watchdog_limit, 0) + " s of wall-clock time";
      else if (WIFSIGNALED(status))
        how = "its worker process died of " + signalText(WTERMSIG(status));
      else
        how = "its worker process exited with status " + std::to_string(WEXITSTATUS(status)) + (w.error.empty() ? "" : ": " + w.error);
      if (!w.ready) {
        // Not the trial's doing: it goes back as it was. Workers that keep dying while they load
        // (a broken binary, no memory) stop the campaign instead of failing every trial.
        queue.emplace_front(w.trial, w.attempt);
        if (WIFEXITED(status) && WEXITSTATUS(status) == 2)
          fatal = "a worker process could not load the experiment (its message is above)";
        else if (WIFEXITED(status) && WEXITSTATUS(status) == 3)
          fatal = "a worker process could not write what it needs (its message is above)";
        else if (++startup_failures >= 3)
          fatal = "three worker processes in a row ended before they were ready (the last: " + how + ")";
      } else if (w.attempt < 2) {
        queue.emplace_front(w.trial, w.attempt + 1);
      } else {
        TrialRecord r;
        r.trial = w.trial;
        r.seed = e.seed;
        r.hardware = e.hardware;
        r.attempts = w.attempt;
        r.o.failure_stage = "worker";
        r.o.failure_kind = w.watchdog_killed ? FailureKind::kHang : FailureKind::kCrash;
        r.o.failure_reason = how + ", in both attempts (seed " + std::to_string(e.seed) + ", trial " + std::to_string(w.trial) + ")";
        r.o.tree_status = w.watchdog_killed ? "HANG" : "CRASH";
        record(toJsonLine(r));
        ++done;
        progress.update(done, ok, w.trial, r.o);
      }
    }
    w = WorkerProcess{};
  };

  try {
    while (fatal.empty()) {
      // Start workers while there are trials for them; hand each idle one the next trial.
      bool any = false;
      for (WorkerProcess& w : workers) {
        if (w.pid < 0 && !queue.empty()) w = spawnWorker(binary, args);
        if (w.pid < 0) continue;
        any = true;
        if (!w.busy && w.to >= 0) {
          if (queue.empty()) {
            close(w.to);  // no more work: it exits
            w.to = -1;
          } else {
            std::tie(w.trial, w.attempt) = queue.front();
            queue.pop_front();
            w.busy = true;
            w.started = std::chrono::steady_clock::now();
            w.watchdog_limit = watchdog.limit();
            sendLine(w.to, "RUN " + std::to_string(w.trial) + " " + std::to_string(w.attempt));
          }
        }
      }
      if (!any) break;
      std::vector<pollfd> fds;
      for (const WorkerProcess& w : workers) fds.push_back({w.pid < 0 ? -1 : w.from, POLLIN, 0});
      if (poll(fds.data(), fds.size(), 200) < 0 && errno != EINTR) throw std::runtime_error("poll: " + std::string(std::strerror(errno)));
      for (size_t k = 0; k < workers.size(); ++k) {
        WorkerProcess& w = workers[k];
        if (w.pid < 0) continue;
        if (fds[k].revents & (POLLIN | POLLHUP | POLLERR)) {
          char buf[65536];
          const ssize_t n = read(w.from, buf, sizeof buf);
          if (n < 0 && errno == EINTR) continue;
          if (n <= 0) {  // its end: exited, killed or crashed; a half line it left is dropped
            finishWorker(w);
            continue;
          }
          w.buffer.append(buf, static_cast<size_t>(n));
          for (size_t nl; (nl = w.buffer.find('\n')) != std::string::npos;) {
            const std::string line = w.buffer.substr(0, nl);
            w.buffer.erase(0, nl + 1);
            if (line.rfind("READY ", 0) == 0) {
              w.ready = true;
              startup_failures = 0;
              w.started = std::chrono::steady_clock::now();  // the watchdog times the trial, not the worker's start-up
              if (line.substr(6) != expected_digest) fatal = "the experiment's files changed while the campaign ran";
            } else if (line.rfind("ERROR ", 0) == 0) {
              w.error = line.substr(6);
            } else if (line.rfind("OUTPUT ", 0) == 0) {
              const size_t tab = line.find('\t');
              output_error = {line.substr(7, tab == std::string::npos ? std::string::npos : tab - 7),
                              tab == std::string::npos ? std::string("unknown cause") : line.substr(tab + 1)};
              w.busy = false;  // its trial is not the cause: it stays unrecorded, for a resume
              fatal = "output";
            } else if (w.busy) {
              const TrialRecord r = fromJsonLine(line, "worker " + std::to_string(w.pid));
              if (r.trial != w.trial) throw std::runtime_error("worker answered for trial " + std::to_string(r.trial));
              record(line);
              watchdog.finished(std::chrono::duration<double>(std::chrono::steady_clock::now() - w.started).count());
              w.busy = false;
              ++done;
              ok += r.o.success;
              progress.update(done, ok, r.trial, r.o);
            }
          }
        } else if (w.busy && !w.watchdog_killed &&  // a worker's start-up gets a minute more
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - w.started).count() >
                       w.watchdog_limit + (w.ready ? 0.0 : 60.0)) {
          w.watchdog_killed = true;  // a true hang: its end arrives as end of output
          kill(w.pid, SIGKILL);
        }
      }
    }
  } catch (...) {
    for (WorkerProcess& w : workers)
      if (w.pid > 0) kill(w.pid, SIGKILL), waitpid(w.pid, nullptr, 0);
    sigaction(SIGPIPE, &old_pipe, nullptr);
    throw;
  }
  for (WorkerProcess& w : workers)
    if (w.pid > 0) kill(w.pid, SIGKILL), waitpid(w.pid, nullptr, 0);
  sigaction(SIGPIPE, &old_pipe, nullptr);
  if (!output_error.first.empty()) throw OutputError(output_error.first, output_error.second);
  if (!fatal.empty()) throw std::runtime_error(fatal);
  jsonl.close();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // The summary streams trials.jsonl back: constant memory in the number of trials.
  SummaryBuilder builder;
  {
    std::ifstream in(out / "trials.jsonl", std::ios::binary);
    long number = 0;
    for (std::string line; std::getline(in, line);) builder.add(fromJsonLine(line, (out / "trials.jsonl").string() + ":" + std::to_string(++number)));
  }
  CampaignSummary s = builder.get();
  s.experiment = e.name;
  s.experiment_file = e.file;
  s.command = co.command_line;
  s.seed = e.seed;
  s.hardware = e.hardware;
  s.tree = e.tree_path;
  s.wall_seconds = wall;
  s.trials_per_second = wall > 0 ? run_now / wall : 0.0;
  s.jobs = e.jobs;
  fillEnvironment(s);
  // Images decide camera-mode outcomes and are what renders show: the renderer is recorded
  // whenever a trial renders anything.
  if (e.render.enabled() || e.perception.mode == PerceptionMode::kCamera) {
    std::string why;
    const auto gl = GlContext::create(e.render.egl, &why);
    s.renderer = gl ? gl->description() : "none: " + why;
  }
  if (!writes) {
    // Nothing ran: the summary of the run that did stands (its wall time, command and machine).
    std::ifstream in(out / "summary.json");
    std::ostringstream text;
    text << in.rdbuf();
    const CampaignSummary there = summaryFromJson(text.str(), (out / "summary.json").string());
    s.command = there.command, s.wall_seconds = there.wall_seconds, s.trials_per_second = there.trials_per_second;
    s.jobs = there.jobs, s.minimanip = there.minimanip, s.mujoco = there.mujoco, s.ompl = there.ompl;
    s.compiler = there.compiler, s.cpu = there.cpu, s.cores = there.cores, s.host = there.host, s.renderer = there.renderer;
  }
  writeFileIfChanged(out / "summary.json", toJson(s) + "\n");
  return summaryTable(s);
}

namespace {

/// A trials.jsonl object without what wall-clock time decides (compute times, the cycle's totals
/// that include them, worker attempts, log paths): what a replay must reproduce exactly.
json outcomeFields(json j) {
  for (const char* k : {"compute_time", "attempts", "bt_log"}) j.erase(k);
  if (j.contains("cycle"))
    for (const char* k : {"perception_time", "plan_pick_time", "plan_place_time", "return_home_time", "total_time"}) j["cycle"].erase(k);
  if (j.contains("stages"))
    for (json& st : j["stages"]) st.erase("compute_seconds");
  return j;
}

void listDifferences(const json& a, const json& b, const std::string& at, std::vector<std::string>& out) {
  if (out.size() >= 8) return;
  if (a.is_object() && b.is_object()) {
    std::set<std::string> keys;
    for (const auto& [k, v] : a.items()) keys.insert(k);
    for (const auto& [k, v] : b.items()) keys.insert(k);
    for (const std::string& k : keys)
      listDifferences(a.contains(k) ? a[k] : json(), b.contains(k) ? b[k] : json(), at.empty() ? k : at + "." + k, out);
  } else if (a.is_array() && b.is_array() && a.size() == b.size()) {
    for (size_t i = 0; i < a.size(); ++i) listDifferences(a[i], b[i], at + "[" + std::to_string(i) + "]", out);
  } else if (a != b) {
    out.push_back(at + ": " + a.dump() + " recorded, " + b.dump() + " replayed");
  }
}

}  // namespace

RenderReplay renderTrial(const std::string& results_dir, uint64_t trial, const std::vector<std::string>& render_sets) {
  const fs::path dir(results_dir);
  const fs::path meta_path = dir / "campaign.json";
  if (!fs::exists(meta_path)) throw InputError(results_dir, "no campaign.json: not a campaign's results folder");
  json meta;
  try {
    meta = json::parse(std::ifstream(meta_path));
  } catch (const json::exception& ex) {
    throw InputError(meta_path.string(), std::string("not JSON: ") + ex.what());
  }
  if (!meta.contains("replay"))
    throw InputError(meta_path.string(), "no 'replay' entry (written by minimanip run since renders exist): run the campaign again to replay it");
  // The trial's recorded line.
  json recorded;
  {
    std::ifstream in(dir / "trials.jsonl");
    for (std::string line; std::getline(in, line);) {
      const json j = json::parse(line, nullptr, false);
      if (!j.is_discarded() && j.value("trial", static_cast<uint64_t>(-1)) == trial) recorded = j;
    }
  }
  if (recorded.is_null())
    throw InputError((dir / "trials.jsonl").string(), "no line for trial " + std::to_string(trial) + " (expected a trial this campaign ran)");
  // The experiment as the campaign loaded it (paths given by --set resolve against its working
  // directory), then what to render: every image and a video unless render_sets say otherwise.
  std::vector<std::string> sets = meta["replay"].value("sets", std::vector<std::string>{});
  for (const char* d : {"render.keyframes=perception,close_gripper,lift,place,open_gripper_release,end",
                        "render.images=rgb,depth,segmentation", "render.video=true", "render.previews=true"})
    sets.push_back(d);
  sets.insert(sets.end(), render_sets.begin(), render_sets.end());
  sets.push_back("render.trials=" + std::to_string(trial));
  const fs::path here = fs::current_path();
  Experiment e;
  try {
    fs::current_path(meta["replay"].value("cwd", here.string()));
    e = loadExperiment(meta["replay"].value("experiment", ""), sets, {}, false);
    fs::current_path(here);
  } catch (...) {
    fs::current_path(here);
    throw;
  }
  const json fingerprint = fingerprintOf(e);
  if (meta.contains("fingerprint") && meta["fingerprint"] != fingerprint)
    throw InputError(e.file, "the experiment is not the campaign's any more (" + differences(meta["fingerprint"], fingerprint, "then", "now") +
                                 "): a replay would not be the same trial");
  const RobotModel robot = loadExperimentRobot(e);
  auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);
  const bt::TreeDocument tree = loadTree(e);
  // A folder of its own, emptied first: the campaign's renders/ stay the campaign's, and two
  // replays' frames never mix. One replay of a trial at a time.
  const fs::path renders = dir / "replays";
  const fs::path trial_dir = trialRenderDir(renders.string(), trial);
  const FolderLock lock(trial_dir, "minimanip render");
  for (const auto& f : fs::directory_iterator(trial_dir))
    if (f.path().filename() != FolderLock::kFileName) fs::remove_all(f.path());
  TrialRunner runner(e, cell, tree, trial_dir.string(), meta.value("date", "2000-01-01 00:00:00"));
  RenderSetup setup = setUpRendering(e);
  if (!setup.renderer) throw std::runtime_error("no renderer on this machine (see the message above)");
  runner.setRenderer(setup.renderer.get(), renders.string(), setup.options);
  TrialRecord r = runOneTrial(e, robot, cell, *world, runner, trial, dir);
  RenderReplay out;
  out.dir = trialRenderDir(renders.string(), trial);
  out.files = runner.rendered();
  out.renderer = setup.renderer->description();
  listDifferences(outcomeFields(recorded), outcomeFields(json::parse(toJsonLine(r))), "", out.differences);
  out.matches = out.differences.empty();
  return out;
}

std::string mergeResults(const std::vector<std::string>& dirs, const std::string& out_dir, const std::string& command) {
  if (dirs.empty()) throw InputError("merge", "expected the results folders to merge");
  // Everything is checked before anything is written.
  std::vector<json> metas;
  for (const std::string& d : dirs) {
    const fs::path meta = fs::path(d) / "campaign.json";
    if (!fs::exists(meta)) throw InputError(d, "no campaign.json: not a campaign's results folder");
    try {
      metas.push_back(json::parse(std::ifstream(meta)));
    } catch (const std::exception& ex) {
      throw InputError(meta.string(), std::string("not a campaign record (") + ex.what() + ")");
    }
  }
  const long trials = metas[0].value("trials", 0L);
  for (size_t i = 1; i < dirs.size(); ++i) {
    const std::string diff = differences(metas[0].value("fingerprint", json::object()), metas[i].value("fingerprint", json::object()),
                                         "in " + dirs[0], "here");
    if (!diff.empty())
      throw InputError((fs::path(dirs[i]) / "campaign.json").string(), "another configuration than " + dirs[0] + ": " + diff);
    if (metas[i].value("trials", 0L) != trials)
      throw InputError((fs::path(dirs[i]) / "campaign.json").string(), "trials is " + std::to_string(metas[i].value("trials", 0L)) +
                                                                         ", " + std::to_string(trials) + " in " + dirs[0]);
  }
  fs::path out = fs::path(out_dir).lexically_normal();
  if (!out.has_filename()) out = out.parent_path();  // "dir/" names dir
  // A new folder, an empty one, or an earlier merge of the same campaign (a Slurm campaign
  // submitted again), which the new merge replaces whole.
  bool replaces = false;
  if (fs::exists(out) && !(fs::is_directory(out) && isEmptyFolder(out))) {
    json there;
    try {
      there = json::parse(std::ifstream(out / "campaign.json"));
    } catch (const std::exception&) {
    }
    if (!there.is_object() || !there.contains("merged_from"))
      throw InputError(out_dir, "exists and is not empty, and is not an earlier merge: merge writes a new folder");
    const std::string diff = differences(there.value("fingerprint", json::object()), metas[0].value("fingerprint", json::object()),
                                         "in " + out_dir, "in " + dirs[0]);
    if (!diff.empty()) throw InputError(out_dir, "holds the merge of another campaign (" + diff + "): merge into a new folder");
    replaces = true;
  }
  std::vector<int> owner(static_cast<size_t>(trials), -1);
  auto eachRecord = [&](const std::function<void(size_t, const std::string&, const TrialRecord&)>& f) {
    for (size_t i = 0; i < dirs.size(); ++i) {
      const fs::path path = fs::path(dirs[i]) / "trials.jsonl";
      std::ifstream in(path, std::ios::binary);
      long number = 0;
      for (std::string line; std::getline(in, line);) {
        const std::string where = path.string() + ":" + std::to_string(++number);
        if (in.eof()) throw InputError(where, "a half-written last line: resume this campaign (run it again) before merging");
        f(i, line, fromJsonLine(line, where));
      }
    }
  };
  eachRecord([&](size_t i, const std::string&, const TrialRecord& r) {
    const std::string where = (fs::path(dirs[i]) / "trials.jsonl").string();
    if (r.trial >= owner.size())
      throw InputError(where, "trial " + std::to_string(r.trial) + " is past the campaign's " + std::to_string(trials) + " trials");
    if (owner[r.trial] >= 0)
      throw InputError(where, "trial " + std::to_string(r.trial) + " is also in " + dirs[static_cast<size_t>(owner[r.trial])]);
    owner[r.trial] = static_cast<int>(i);
    if (!r.bt_log.empty() && !fs::exists(fs::path(dirs[i]) / r.bt_log))
      throw InputError(where, "trial " + std::to_string(r.trial) + "'s tree log " + r.bt_log + " is missing");
  });
  std::vector<long> missing;
  for (size_t t = 0; t < owner.size(); ++t)
    if (owner[t] < 0) missing.push_back(static_cast<long>(t));
  if (!missing.empty()) {
    std::string list;
    for (size_t k = 0; k < std::min<size_t>(missing.size(), 8); ++k) list += (k ? ", " : "") + std::to_string(missing[k]);
    throw InputError(out_dir, std::to_string(missing.size()) + " of the " + std::to_string(trials) +
                                  " trials are in none of the folders (" + list + (missing.size() > 8 ? ", ..." : "") +
                                  "): a shard missing or unfinished? Run it (again), then merge");
  }

  // Write: trials.jsonl in the folders' order, the tree logs beside it, the summary recomputed.
  // Into a folder beside it, renamed into place when complete: a failed merge removes it again,
  // and one that was killed is cleared by the next.
  const fs::path work = out.string() + ".partial";
  const FolderLock lock(work, "minimanip merge");  // one merge at a time
  CampaignSummary s;
  try {
    for (const auto& f : fs::directory_iterator(work))
      if (f.path().filename() != FolderLock::kFileName) fs::remove_all(f.path());  // a merge that was killed
    SummaryBuilder builder;
    {
      AppendFile jsonl(work / "trials.jsonl");
      eachRecord([&](size_t i, const std::string& line, const TrialRecord& r) {
        jsonl.appendLine(line);
        builder.add(r);
        if (!r.bt_log.empty()) {
          createDirectories((work / r.bt_log).parent_path());
          std::error_code ec;
          fs::copy_file(fs::path(dirs[i]) / r.bt_log, work / r.bt_log, fs::copy_options::overwrite_existing, ec);
          if (ec) throw OutputError((work / r.bt_log).string(), ec.message());
        }
      });
    }
    for (const std::string& d : dirs)  // camera renders, when a campaign has them
      if (fs::exists(fs::path(d) / "renders")) {
        std::error_code ec;
        fs::copy(fs::path(d) / "renders", work / "renders", fs::copy_options::recursive | fs::copy_options::overwrite_existing, ec);
        if (ec) throw OutputError((work / "renders").string(), ec.message());
      }
    if (fs::exists(fs::path(dirs[0]) / "config.resolved.yaml")) {
      std::ifstream in{fs::path(dirs[0]) / "config.resolved.yaml"};
      std::ostringstream text;
      text << "# " << command << "\n" << in.rdbuf();
      writeFileAtomically(work / "config.resolved.yaml", text.str());
    }
    json meta = metas[0];
    meta["command"] = command;
    meta["shard"] = "0/1";
    meta["merged_from"] = dirs;
    writeFileAtomically(work / "campaign.json", meta.dump(2, ' ', false, json::error_handler_t::replace) + "\n");

    s = builder.get();
    double wall = 0;
    for (const std::string& d : dirs) {
      const fs::path p = fs::path(d) / "summary.json";
      if (!fs::exists(p)) continue;
      std::ifstream in(p);
      std::ostringstream text;
      text << in.rdbuf();
      const CampaignSummary shard = summaryFromJson(text.str(), p.string());
      if (d == dirs[0]) {
        s.experiment = shard.experiment, s.experiment_file = shard.experiment_file, s.seed = shard.seed;
        s.hardware = shard.hardware, s.tree = shard.tree, s.jobs = shard.jobs;
      }
      wall += shard.wall_seconds;
    }
    s.command = command;
    s.wall_seconds = wall;
    s.trials_per_second = wall > 0 ? s.trials / wall : 0.0;
    fillEnvironment(s);
    writeFileAtomically(work / "summary.json", toJson(s) + "\n");
  } catch (...) {
    std::error_code ec;
    fs::remove_all(work, ec);  // nothing half-made is left behind
    throw;
  }
  // Into place: an empty folder is removed, an earlier merge set aside and removed once the new
  // one stands.
  const fs::path old = out.string() + ".old";
  std::error_code ec;
  if (replaces) {
    fs::remove_all(old);
    fs::rename(out, old, ec);
  } else if (fs::exists(out)) {
    fs::remove_all(out, ec);  // empty, or holding only a lock file (checked above)
  }
  if (!ec) fs::rename(work, out, ec);
  if (ec) throw OutputError(out.string(), ec.message());
  if (replaces) fs::remove_all(old);
  return summaryTable(s);
}

}  // namespace mm
