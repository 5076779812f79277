#include "campaign/campaign.h"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "campaign/record.h"
#include "campaign/results_folder.h"
#include "campaign/trial.h"
#include "campaign/worker.h"
#include "core/child_process.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/folder_lock.h"
#include "core/utf8.h"
#include "core/pose.h"
#include "core/rng.h"
#include "kinematics/ik.h"
#include "render/gl_context.h"
#include "render/renderer.h"
#include "sim/mjcf_robot.h"
#include "sim/sim_world.h"

namespace mm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A rate with its Wilson interval and its count: "97.5% [95% CI 93.1, 99.2] of 120 attempts".
std::string rateText(const Rate& r, const char* of) {
  return r.n == 0 ? std::string("n/a (none)")
                  : fixedText(100 * r.value, 1) + "% [95% CI " + fixedText(100 * r.ci95[0], 1) + ", " + fixedText(100 * r.ci95[1], 1) +
                        "] of " + std::to_string(r.n) + of;
}

}  // namespace

std::string summaryTable(const CampaignSummary& s) {
  const long n = s.trials;
  std::ostringstream t;
  t << std::fixed;
  const std::string rule(64, '=');
  t << rule << "\n  Bin-Picking Performance Report: " << s.experiment << " (" << s.hardware << ", seed " << s.seed << ")\n" << rule << "\n";
  t << std::setprecision(1);
  t << "  Trials:            " << n << (s.goal == "clear_bin" ? " (each asked to clear its bin)" : " (each asked to place one object)") << "\n";
  // Clearing the bin: the per-object yield is the headline.
  if (s.goal == "clear_bin") {
    if (s.objects_spawned > 0)
      t << "  Object Yield:      " << std::setprecision(1) << 100 * s.object_yield << "%  [95% CI " << 100 * s.object_yield_ci95.at(0)
        << ", " << 100 * s.object_yield_ci95.at(1) << "] of " << s.objects_spawned << " objects; first-pass "
        << 100 * s.object_first_pass_yield << "% [95% CI " << 100 * s.object_first_pass_ci95.at(0) << ", "
        << 100 * s.object_first_pass_ci95.at(1) << "]\n";
    t << "  Bins emptied:      " << s.bins_cleared << " of " << n << "\n";
  }
  t << "  First-pass Yield:  " << 100.0 * s.first_pass_yield << "%  [95% CI " << 100 * s.first_pass_ci95[0] << ", "
    << 100 * s.first_pass_ci95[1] << "]\n";
  t << "  Overall Yield:     " << 100.0 * s.overall_yield << "%  [95% CI " << 100 * s.overall_ci95[0] << ", " << 100 * s.overall_ci95[1]
    << "]\n";
  t << "  Recovery Rate:     "
    << (s.recoveries_needed ? fixedText(100.0 * s.recovery_rate, 1) + "% (" + std::to_string(s.recovered) + " of " +
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
  if (const PoseRecall& p = s.pose_recall; p.views > 0 && p.targets == 0) {
    t << "  Pose Recall (BOP): no targets in " << p.views << " views\n";
  } else if (p.views > 0) {
    t << "  Pose Recall (BOP): AR " << p.ar << " (VSD " << p.ar_vsd << ", MSSD " << p.ar_mssd << ", MSPD " << p.ar_mspd << ") over "
      << p.targets << " targets in " << p.views << " views\n";
    t << "                     MSSD < 0.1 d: " << rateText(p.mssd_10, " targets at least half visible") << "\n";
    t << "  Pose Estimation:   " << fixedText(1000 * p.seconds_per_view_mean, 0) << " ms a view (mean), "
      << fixedText(1000 * p.seconds_per_view_max, 0) << " ms (max), wall\n";
  }
  t << "  Collisions:        " << s.collision_events << " events in " << n << " trials\n";
  const std::string spawns = s.spawn_failures ? "; " + std::to_string(s.spawn_failures) + " spawns failed" : std::string();
  if (s.goal == "clear_bin")
    t << "  Objects placed:    " << s.objects_placed << " of " << s.objects_spawned << " (" << s.objects_left_in_bin << " left in bins" << spawns
      << ")\n";
  else  // one object a trial: the others were never asked for
    t << "  Objects placed:    " << s.objects_placed << " (one a trial asked); " << s.objects_left_in_bin
      << (s.objects_left_in_bin == 1 ? " object" : " objects") << " left in the bins" << spawns << "\n";
  t << "  Max Tracking Err:  " << std::setprecision(4) << s.max_tracking_error << " rad\n";
  if (!s.clutter_by_grade.empty()) {  // generated objects: the clutter-removal protocol's figures
    const auto rate = rateText;
    t << std::string(64, '-') << "\n  Clutter removal (grasp success: attempts whose object reached the tray;\n"
      << "  declutter: objects in the tray of those in the bins)\n";
    t << "    " << std::left << std::setw(8) << "all" << std::right << " GSR " << rate(s.clutter.grasp_success, " attempts") << "\n"
      << "    " << std::setw(8) << "" << " DR  " << rate(s.clutter.declutter, " objects") << "\n";
    for (const ClutterStats& g : s.clutter_by_grade)
      t << "    " << std::left << std::setw(8) << g.grade << std::right << " GSR " << rate(g.grasp_success, " attempts") << "; DR "
        << rate(g.declutter, " objects") << "\n";
    std::string results;
    for (const auto& [result, count] : s.attempt_results) results += (results.empty() ? "" : ", ") + result + " " + std::to_string(count);
    t << "    attempts: " << (results.empty() ? "none" : results) << "\n";
  }
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
    t << std::setprecision(1) << "  MTBF:              " << (s.mtbf >= 0 ? fixedText(s.mtbf, 1) + " s (simulated)" : std::string("no unrecovered failure"))
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

}  // namespace

namespace {

// The IK solver the trials will use, made now (a closed form that does not fit the arm's shape
// is bad input before any trial, not a crash in every one), and, for a closed form, tried: the
// poses of 20 seeded random configurations within the limits must come back, each within 1 mm
// and 0.01 rad, from at least half of them (a closed form of another arm's shape finds none).
void checkIkFits(const Experiment& e, const RobotModel& robot) {
  const std::unique_ptr<IkSolver> ik = makeIkSolver(e.task.ik_solver, robot);
  if (ik->name() != "analytic" && ik->name() != "hybrid") return;
  Rng rng = Rng::stream(e.seed, 0, Purpose::kIk, 0x1cf175);  // a sub-stream of its own: no trial draws from it
  int fits = 0;
  const int n = 20;
  for (int k = 0; k < n; ++k) {
    VecX q(robot.dof());
    for (int j = 0; j < robot.dof(); ++j) q[j] = rng.uniform(robot.lower()[j], robot.upper()[j]);
    IkRequest req = e.task.ik;
    req.target = robot.fk(q);
    req.seed = robot.home();
    req.limit_margin = 0;  // the configuration itself may sit at a limit
    req.time_cap = 10.0;   // the work-unit budget decides; the wall-clock cap is only a safety net
    const IkResult r = ik->solve(req, rng);
    if (!r.ok()) continue;
    const Pose T = robot.fk(r.q());
    fits += (T.translation() - req.target.translation()).norm() < 1e-3 && angleBetween(T.linear(), req.target.linear()) < 0.01;
  }
  if (2 * fits < n)
    throw InputError(robot.spec().file, "the closed-form IK '" + robot.spec().analytic_ik + "' does not fit this arm: it solved " +
                                            std::to_string(fits) + " of " + std::to_string(n) +
                                            " poses the arm reaches (expected the arm it was written for; leave analytic_ik out "
                                            "for a numerical solver)");
}

}  // namespace

namespace {

// The external component a tree asks (usesExternal) must be one that can be started: a command, a
// program found, a working directory that is one. Exit 2 before any trial, naming where it was set.
void checkExternalComponent(const Experiment& e) {
  const ExternalOptions& x = e.task.external;
  auto where = [&](const char* key) {
    const std::string& origin = e.params.origin(key);
    return origin.empty() ? "--set " + std::string(key) : origin == "(default)" ? e.file : origin;
  };
  const std::string asked = e.task.grasp_source == TaskOptions::GraspSource::kExternal
                                ? "grasp.source is external"
                                : "the tree (" + e.tree_path + ") has WaitForGraspCandidates source=\"external\"";
  if (x.argv().empty())
    throw InputError(where("external.command"), asked + ", and external.command is " + (x.command == "none" ? "none" : "blank") +
                                                        ": expected the command that starts the component (e.g. /usr/bin/python3 "
                                                        "tools/external_grasps.py)");
  std::error_code ec;
  if (!x.cwd.empty() && !fs::is_directory(x.cwd, ec))
    throw InputError(where("external.cwd"), "external.cwd '" + x.cwd + "' is not a folder");
  try {
    resolveProgram(x.argv()[0], x.cwd);
  } catch (const std::runtime_error& err) {
    throw InputError(where("external.command"), "external.command '" + x.command + "': " + err.what());
  }
}

}  // namespace

std::string robotAsLoaded(const RobotModel& robot) {
  const RobotSpec& s = robot.spec();
  std::ostringstream o;
  o.precision(4);
  o << "robot " << s.name << " (" << s.file << "): " << s.joints.size() << " joints, base " << s.base_link;
  if (!s.flange_link.empty()) o << ", flange " << s.flange_link << " (" << s.flange_choice << ")";
  o << ", gripper " << s.gripper.name << "\n";
  o << "home [";
  for (size_t i = 0; i < s.home.size(); ++i) o << (i ? ", " : "") << s.home[i];
  o << "] (" << (s.home_source == "yaml" ? "the robot's files" : s.home_source == "keyframe" ? "the MJCF keyframe 'home'"
                 : s.home_source == "computed" ? "computed: none given; the clear gripper-down pose above the bin farthest from the limits"
                                               : "each joint at 0")
    << ")\n";
  for (const std::string& n : s.notes) o << "note: " << n << "\n";
  return o.str();
}

std::string checkCampaignInput(const Experiment& e) {
  // The text files the experiment names: UTF-8, checked where they enter (names in them reach
  // the records). The YAML experiment itself was checked as it was read.
  {
    const RobotSpec spec = loadAnyRobotSpec(e.robot_path, e.gripper_path == "default" ? "" : e.gripper_path);
    for (const std::string& f : {e.robot_path, spec.sidecar, spec.gripper.file, e.scene_path, e.tree_path, e.spawn.catalogue,
                                 e.perception.extrinsics == "simulator" ? std::string() : e.perception.extrinsics}) {
      std::error_code ec;
      if (f.empty() || !fs::exists(f, ec)) continue;  // a missing file is named by its own loader
      if (ec || !fs::is_regular_file(f, ec) || ec) throw InputError(f, "cannot be read: " + (ec ? ec.message() : "not a file"));
      std::ifstream in(f, std::ios::binary);
      if (!in) throw InputError(f, "cannot be read: " + errnoText(errno));
      std::ostringstream text;
      text << in.rdbuf();
      requireUtf8File(text.str(), f);
    }
  }
  const RobotModel robot = loadExperimentRobot(e);
  checkIkFits(e, robot);
  const std::string as_loaded = robotAsLoaded(robot);
  const auto world = loadWorld(e, robot);
  makeCell(e, robot, *world);
  const bt::TreeDocument tree = loadTree(e);
  // The cameras named must exist; camera perception cannot run without a renderer.
  const bool camera = needsCamera(e, tree);  // a bad source= of the tree is exit 2 here
  if (usesExternal(e, tree)) checkExternalComponent(e);
  else if (e.task.external.oracle)
    throw InputError(e.params.origin("external.oracle").empty() ? "--set external.oracle" : e.params.origin("external.oracle"),
                     "external.oracle gives the external component the renderer's segmentation, but nothing asks the component "
                     "(grasp.source external, or a tree's WaitForGraspCandidates source=\"external\")");
  if (camera || e.render.enabled()) {
    std::string why;
    const auto renderer = Renderer::create(e.render.egl, &why);
    if (!renderer && camera)
      throw InputError(e.file, std::string(e.perception.mode == PerceptionMode::kCamera            ? "perception.mode camera"
                                           : e.task.grasp_source == TaskOptions::GraspSource::kCloud ? "grasp.source cloud"
                                           : e.task.grasp_source == TaskOptions::GraspSource::kExternal ? "grasp.source external"
                                                                                                    : "the tree's WaitForGraspCandidates source= (" + e.tree_path + ")") +
                                   " needs an offscreen OpenGL context, and none can be made here: " + why);
    if (renderer && camera)
      renderer->camera(*world, e.perception.camera, 64, 48, e.file, "perception.camera");
    if (renderer && e.render.enabled()) renderer->camera(*world, e.render.camera, 64, 48, e.file);
  }
  return as_loaded;
}

std::string runCampaign(const Experiment& e, const CampaignOptions& co) {
  // Of two runs started on one folder, the first started keeps it, however long its input takes.
  const FolderLock claim = FolderLock::claimBeforeStart(co.out_dir, "minimanip run");
  // Everything that can be bad input is loaded and checked before anything is written.
  const std::string robot_text = checkCampaignInput(e);
  if (e.progress != "none") std::cerr << robot_text;
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
    // The robot as loaded (flange, home, what was changed of its files), as comments: not keys.
    std::string robot_comment;
    std::istringstream lines(robot_text);
    for (std::string l; std::getline(lines, l);) robot_comment += "# " + l + "\n";
    writeFileIfChanged(out / "config.resolved.yaml", "# " + co.command_line + "\n" + robot_comment + e.params.toYaml());
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
        how = "stopped by the watchdog after " + fixedText(w.watchdog_limit, 0) + " s of wall-clock time";
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
        r.oracle = oracleOf(e);
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
  s.goal = e.goal;
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
  if (e.render.enabled() || needsCamera(e)) {
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

}  // namespace mm
