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
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "campaign/stats.h"
#include "campaign/trial.h"
#include "core/error.h"
#include "planning/planner.h"
#include "sim/hardware.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
constexpr int kSchema = 1;

json nullable(const std::string& s) { return s.empty() ? json(nullptr) : json(s); }

json trialJson(const Experiment& e, uint64_t trial, const SpawnResult& spawn, const TrialOutcome& o,
               const std::string& bt_log) {
  json j;
  j["schema"] = kSchema;
  j["trial"] = trial;
  j["seed"] = e.seed;
  j["hardware"] = e.hardware;
  j["success"] = o.success;
  j["failure_stage"] = nullable(o.failure_stage);
  j["failure_reason"] = nullable(o.failure_reason);
  j["failure_kind"] = o.success ? json(nullptr) : json(failureKindName(o.failure_kind));
  j["tree"] = nullable(o.tree);
  j["tree_status"] = nullable(o.tree_status);
  j["ticks"] = o.ticks;
  j["sim_unstable"] = o.sim_unstable;
  j["dropped"] = o.dropped;
  j["objects_in_bin"] = spawn.active.size();
  j["spawn_attempts"] = spawn.attempts;
  j["target_object"] = o.target_object;
  j["grasp_candidates_tried"] = o.grasp_candidates_tried;
  j["grasp_opening"] = o.grasp_opening;
  // The source's TrialResult time breakdown [s]: planning and perception in compute wall time,
  // execution in simulated time; total = their sum (the cycle time).
  j["cycle"] = {{"perception_time", o.perception_time},   {"plan_pick_time", o.plan_pick_time},
                {"execute_pick_time", o.execute_pick_time}, {"plan_place_time", o.plan_place_time},
                {"execute_place_time", o.execute_place_time}, {"return_home_time", o.return_home_time},
                {"total_time", o.total_time}};
  j["sim_time"] = o.sim_time;
  j["compute_time"] = o.compute_time;
  j["place_position_error"] = o.place_position_error;
  j["place_orientation_error"] = o.place_orientation_error;
  j["collision_count"] = o.collision_count;
  j["collision_log"] = o.collision_log;
  j["max_tracking_error"] = o.max_tracking_error;
  j["collision_checks"] = o.collision_checks;
  j["recovery"] = {{"needed", o.recovery_needed}, {"success", o.recovery_success}, {"attempts", o.recovery_attempts}};
  json picks = json::array();
  for (const PickRecord& p : o.picks)
    picks.push_back({{"object", p.object},
                     {"at_target", p.at_target},
                     {"placed", p.placed},
                     {"position_error", p.position_error},
                     {"orientation_error", p.orientation_error},
                     {"target", {p.T_world_target.translation().x(), p.T_world_target.translation().y(), p.T_world_target.translation().z()}},
                     {"grasp_candidates_tried", p.grasp_candidates_tried},
                     {"grasp_opening", p.grasp_opening},
                     {"reason", nullable(p.reason)}});
  j["picks"] = picks;
  j["objects_placed"] = std::count_if(o.picks.begin(), o.picks.end(), [](const PickRecord& p) { return p.placed; });
  j["objects_left_in_bin"] = o.objects_left_in_bin;
  j["reported_total"] = o.reported_total >= 0 ? json(o.reported_total) : json(nullptr);
  json failures = json::array();
  for (const RecordedFailure& f : o.failures)
    failures.push_back({{"stage", f.failure.stage},
                        {"kind", failureKindName(f.failure.kind)},
                        {"reason", f.failure.reason},
                        {"sim_time", f.sim_time},
                        {"handled", f.handled}});
  j["failures"] = failures;
  j["bt_log"] = nullable(bt_log);
  json stages = json::array();
  for (const auto& s : o.stages)
    stages.push_back({{"name", s.name}, {"ok", s.ok}, {"sim_seconds", s.sim_seconds}, {"compute_seconds", s.compute_seconds}});
  j["stages"] = stages;
  return j;
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
  json j;
  std::string table;
};

Summary summarize(const Experiment& e, const std::vector<json>& trials, double wall_seconds, const CampaignOptions& co) {
  const long n = static_cast<long>(trials.size());
  long ok = 0, first_pass = 0, needed = 0, recovered = 0, unstable = 0, dropped = 0, collisions = 0, placed = 0,
       left = 0, cleared = 0, timeouts = 0;
  double all_time = 0;  // cycle time of every trial, failed ones included
  std::vector<double> cycle, sim, place_mm, orient_deg, track;
  std::map<std::string, std::vector<double>> breakdown;
  std::map<std::string, long> failures;
  const char* keys[] = {"perception_time", "plan_pick_time", "execute_pick_time", "plan_place_time",
                        "execute_place_time", "return_home_time"};
  for (const json& t : trials) {
    const bool s = t["success"];
    const bool rn = t["recovery"]["needed"];
    collisions += t["collision_count"].get<long>();
    placed += t["objects_placed"].get<long>();
    all_time += t["cycle"]["total_time"].get<double>();
    left += t["objects_left_in_bin"].get<long>();
    cleared += t["objects_left_in_bin"].get<long>() == 0;
    timeouts += t["tree_status"] == "TIMEOUT";
    unstable += t["sim_unstable"].get<bool>();
    dropped += t["dropped"].get<bool>();
    track.push_back(t["max_tracking_error"]);
    if (rn) ++needed, recovered += t["recovery"]["success"].get<bool>();
    if (!s) {
      failures[t["failure_stage"].is_null() ? "unknown" : t["failure_stage"].get<std::string>()]++;
      continue;
    }
    ++ok;
    if (!rn) ++first_pass;
    cycle.push_back(t["cycle"]["total_time"]);
    sim.push_back(t["sim_time"]);
    place_mm.push_back(1000.0 * t["place_position_error"].get<double>());
    orient_deg.push_back(180.0 / M_PI * t["place_orientation_error"].get<double>());
    for (const char* k : keys) breakdown[k].push_back(t["cycle"][k]);
  }
  const auto [fl, fh] = wilson95(first_pass, n);
  const auto [ol, oh] = wilson95(ok, n);
  const Moments c = moments(cycle), s = moments(sim), pm = moments(place_mm), od = moments(orient_deg), tr = moments(track);
  json j;
  j["schema"] = kSchema;
  j["experiment"] = e.name;
  j["experiment_file"] = e.file;
  j["command"] = co.command_line;
  j["seed"] = e.seed;
  j["hardware"] = e.hardware;
  j["trials"] = n;
  j["successes"] = ok;
  j["first_pass_yield"] = {{"value", n ? double(first_pass) / n : 0.0}, {"ci95", {fl, fh}}};
  j["overall_yield"] = {{"value", n ? double(ok) / n : 0.0}, {"ci95", {ol, oh}}};
  j["recovery_rate"] = needed ? json(double(recovered) / needed) : json(nullptr);
  j["recoveries_needed"] = needed;
  j["cycle_time"] = {{"mean", c.mean}, {"std", c.std}, {"max", c.max}, {"n", c.n}};
  j["sim_time"] = {{"mean", s.mean}, {"std", s.std}, {"max", s.max}};
  // Objects placed per hour of cell time, every trial's time counted (failed ones too).
  const double per_hour = all_time > 0 ? 3600.0 * placed / all_time : 0.0;
  j["throughput_per_hour"] = per_hour;
  j["time_per_pick"] = placed > 0 ? json(all_time / placed) : json(nullptr);
  json bd;
  for (const char* k : keys) bd[k] = moments(breakdown[k]).mean;
  j["mean_time_breakdown"] = bd;
  j["place_position_error_mm"] = {{"mean", pm.mean}, {"max", pm.max}};
  j["place_orientation_error_deg"] = {{"mean", od.mean}, {"max", od.max}};
  j["collision_events"] = collisions;
  j["collisions_per_100_trials"] = n ? 100.0 * collisions / n : 0.0;
  j["max_tracking_error_rad"] = tr.max;
  j["sim_unstable"] = unstable;
  j["dropped"] = dropped;
  j["failure_stages"] = failures;
  j["tree"] = e.tree_path;
  j["objects_placed"] = placed;
  j["objects_left_in_bin"] = left;
  j["bins_cleared"] = cleared;
  j["timeouts"] = timeouts;
  j["wall_seconds"] = wall_seconds;
  j["trials_per_second"] = wall_seconds > 0 ? n / wall_seconds : 0.0;
  j["environment"] = {{"minimanip", MINIMANIP_VERSION},
                      {"mujoco", mujocoVersion()},
                      {"ompl", omplVersion()},
                      {"compiler", std::string("gcc ") + __VERSION__},
                      {"cpu", cpuModel()},
                      {"cores", std::thread::hardware_concurrency()},
                      {"host", hostName()},
                      {"jobs", e.jobs}};

  std::ostringstream t;
  t << std::fixed;
  const std::string rule(64, '=');
  t << rule << "\n  Bin-Picking Performance Report: " << e.name << " (" << e.hardware << ", seed " << e.seed << ")\n" << rule << "\n";
  t << std::setprecision(1);
  t << "  Trials:            " << n << "\n";
  t << "  First-pass Yield:  " << 100.0 * first_pass / std::max(n, 1L) << "%  [95% CI " << 100 * fl << ", " << 100 * fh << "]\n";
  t << "  Overall Yield:     " << 100.0 * ok / std::max(n, 1L) << "%  [95% CI " << 100 * ol << ", " << 100 * oh << "]\n";
  t << "  Recovery Rate:     " << (needed ? std::to_string(100.0 * recovered / needed) + "%" : std::string("n/a (no recovery needed)")) << "\n";
  t << std::string(64, '-') << "\n" << std::setprecision(2);
  t << "  Mean Cycle Time:   " << c.mean << " +/- " << c.std << " s   (max " << c.max << " s)\n";
  t << "  Throughput:        " << std::setprecision(0) << per_hour << " picks/h (objects placed per hour, all trials' time)\n";
  t << std::string(64, '-') << "\n  Time Breakdown (mean over successes):\n";
  const char* labels[] = {"Perception  ", "Plan Pick   ", "Exec Pick   ", "Plan Place  ", "Exec Place  ", "Return Home "};
  for (int i = 0; i < 6; ++i)
    t << "    " << labels[i] << std::setw(9) << std::setprecision(1) << 1000 * bd[keys[i]].get<double>() << " ms"
      << (i == 0 || i == 1 || i == 3 ? "  (compute)" : (i == 5 ? "  (plan + sim)" : "  (sim)")) << "\n";
  t << std::string(64, '-') << "\n" << std::setprecision(2);
  t << "  Place Error:       " << pm.mean << " mm (mean), " << pm.max << " mm (max); " << od.mean << " deg (mean)\n";
  t << "  Collisions:        " << collisions << " events in " << n << " trials\n";
  t << "  Objects placed:    " << placed << " (" << left << " left in bins; " << cleared << " of " << n << " bins empty)\n";
  t << "  Max Tracking Err:  " << std::setprecision(4) << tr.max << " rad\n";
  if (!failures.empty()) {
    t << std::string(64, '-') << "\n  Failure Analysis:\n";
    for (const auto& [stage, count] : failures) t << "    " << stage << ": " << count << "\n";
  }
  t << rule << "\n";
  return {j, t.str()};
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
  std::vector<json> results(e.trials);
  std::atomic<long> next{0};
  std::mutex mu;
  long done = 0, ok = 0;
  Progress progress(e.progress, e.trials);
  std::exception_ptr error;
  auto worker = [&](SimWorld& world) {
    try {
      TrialRunner runner(e, cell, tree, (out / "bt").string(), date);
      for (long i; (i = next++) < e.trials;) {
        const uint64_t trial = static_cast<uint64_t>(i);
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
          o = runner.run(*hw, trial, bt_log);
        }
        json j = trialJson(e, trial, spawn, o, bt_log.empty() ? "" : fs::relative(bt_log, out).string());
        std::lock_guard<std::mutex> lock(mu);
        jsonl << j.dump() << "\n";
        jsonl.flush();
        results[i] = std::move(j);
        ++done;
        ok += o.success;
        progress.update(done, ok, trial, o);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(mu);
      if (!error) error = std::current_exception();
      next = e.trials;  // stop the others
    }
  };
  std::vector<std::thread> threads;
  for (int k = 1; k < e.jobs; ++k) threads.emplace_back(worker, std::ref(*worlds[k]));
  worker(*worlds[0]);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Summary s = summarize(e, results, wall, co);
  writeAtomically(out / "summary.json", s.j.dump(2) + "\n");
  return s.table;
}

}  // namespace mm
