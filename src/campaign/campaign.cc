#include "campaign/campaign.h"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "campaign/record.h"
#include "campaign/stats.h"
#include "campaign/trial.h"
#include "core/error.h"
#include "planning/planner.h"
#include "sim/hardware.h"
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
  r.objects_in_bin = static_cast<int>(spawn.active.size());
  r.spawn_attempts = spawn.attempts;
  r.bt_log = bt_log;
  r.o = std::move(o);
  return r;
}

void writeAtomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, path);
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

struct Summary {
  std::string json, table;
};

Summary summarize(const Experiment& e, const std::vector<TrialRecord>& trials, double wall_seconds, const CampaignOptions& co) {
  CampaignSummary s = summarizeTrials(trials);
  s.experiment = e.name;
  s.experiment_file = e.file;
  s.command = co.command_line;
  s.seed = e.seed;
  s.hardware = e.hardware;
  s.tree = e.tree_path;
  s.wall_seconds = wall_seconds;
  s.trials_per_second = wall_seconds > 0 ? s.trials / wall_seconds : 0.0;
  s.minimanip = MINIMANIP_VERSION;
  s.mujoco = mujocoVersion();
  s.ompl = omplVersion();
  s.compiler = std::string("gcc ") + __VERSION__;
  s.cpu = cpuModel();
  s.cores = std::thread::hardware_concurrency();
  s.host = hostName();
  s.jobs = e.jobs;

  const long n = s.trials;
  std::ostringstream t;
  t << std::fixed;
  const std::string rule(64, '=');
  t << rule << "\n  Bin-Picking Performance Report: " << e.name << " (" << e.hardware << ", seed " << e.seed << ")\n" << rule << "\n";
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
      << 1000 * s.breakdown[key] << " ms\n";
  t << std::string(64, '-') << "\n" << std::setprecision(2);
  t << "  Place Error:       " << s.place_mm_mean << " mm (mean), " << s.place_mm_max << " mm (max); " << s.orient_deg_mean
    << " deg (mean)\n";
  t << "  Collisions:        " << s.collision_events << " events in " << n << " trials\n";
  t << "  Objects placed:    " << s.objects_placed << " (" << s.objects_left_in_bin << " left in bins; " << s.bins_cleared << " of "
    << n << " bins empty)\n";
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
  return {toJson(s), t.str()};
}

class Progress {
 public:
  Progress(const std::string& mode, long total) : total_(total), t0_(std::chrono::steady_clock::now()) {
    bar_ = mode == "bar" || (mode == "auto" && isatty(STDERR_FILENO));
    quiet_ = mode == "none";
  }
  void update(long done, long ok, uint64_t trial, const TrialOutcome& o) {
    if (quiet_) return;
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    const double eta = done ? el / done * (total_ - done) : 0;
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
  long total_;
  std::chrono::steady_clock::time_point t0_;
  bool bar_ = false, quiet_ = false;
};

}  // namespace

std::string runCampaign(const Experiment& e, const CampaignOptions& co) {
  // Everything that can be bad input is loaded and checked before anything is written.
  const RobotModel robot = RobotModel::load(e.robot_path);
  std::vector<std::unique_ptr<SimWorld>> worlds;
  for (int k = 0; k < e.jobs; ++k) worlds.push_back(SimWorld::load(e.scene_path, robot));
  const Cell cell = makeCell(e, robot, *worlds[0]);
  const bt::TreeDocument tree = loadTree(e);

  const fs::path out(co.out_dir);
  fs::create_directories(out);
  for (const char* f : {"trials.jsonl", "summary.json", "config.resolved.yaml"}) fs::remove(out / f);
  fs::remove_all(out / "bt");
  if (e.bt_log != "none") fs::create_directories(out / "bt");
  const std::string date = localDateTime();
  writeAtomically(out / "config.resolved.yaml", "# " + co.command_line + "\n" + e.params.toYaml());
  std::ofstream jsonl(out / "trials.jsonl", std::ios::app);

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<uint64_t> order;
  for (int64_t t : e.only) order.push_back(static_cast<uint64_t>(t));
  if (order.empty())
    for (int64_t t = 0; t < e.trials; ++t) order.push_back(static_cast<uint64_t>(t));
  const long count = static_cast<long>(order.size());
  std::vector<TrialRecord> results(count);
  std::atomic<long> next{0};
  std::mutex mu;
  long done = 0, ok = 0;
  Progress progress(e.progress, count);
  std::exception_ptr error;
  auto worker = [&](SimWorld& world) {
    try {
      TrialRunner runner(e, cell, tree, (out / "bt").string(), date);
      for (long i; (i = next++) < count;) {
        const uint64_t trial = order[i];
        Rng rng_scene = Rng::stream(e.seed, trial, Purpose::kScene);
        const SpawnResult spawn = spawnObjects(world, robot, cell.T_world_bin, cell.bin_half, rng_scene, e.spawn);
        TrialOutcome o;
        std::string bt_log;
        if (!spawn.ok) {
          o.failure_stage = "spawn";
          o.failure_reason = spawn.reason;
        } else {
          auto hw = e.hardware == "mock" ? makeMockHardware(world, robot, spawn.active)
                                         : makeMujocoHardware(world, robot, spawn.active);
          o = runner.run(*hw, world, trial, bt_log);
        }
        TrialRecord record = makeRecord(e, trial, spawn, std::move(o), bt_log.empty() ? "" : fs::relative(bt_log, out).string());
        const std::string line = toJsonLine(record);
        std::lock_guard<std::mutex> lock(mu);
        jsonl << line << "\n";
        jsonl.flush();
        ++done;
        ok += record.o.success;
        progress.update(done, ok, trial, record.o);
        results[i] = std::move(record);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(mu);
      if (!error) error = std::current_exception();
      next = count;  // stop the others
    }
  };
  std::vector<std::thread> threads;
  for (int k = 1; k < e.jobs; ++k) threads.emplace_back(worker, std::ref(*worlds[k]));
  worker(*worlds[0]);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Summary s = summarize(e, results, wall, co);
  writeAtomically(out / "summary.json", s.json + "\n");
  return s.table;
}

}  // namespace mm
