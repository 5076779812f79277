#include "campaign/experiment.h"
#include "campaign/robot_home.h"
#include "campaign/trial.h"
#include "bt/factory.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <thread>

#include "sim/mjcf_robot.h"
#include "core/error.h"
#include "sim/hardware.h"

namespace mm {

void Experiment::declare(ConfigArchive& a) {
  a.value("name", name, "campaign name; results go to results/<name>/ unless --out");
  a.value("trials", trials, {1, 1e7}, "", "number of trials (--trials overrides)");
  a.list("only", only, {0, 1e7},
         "run only these trials (indices below trials), each exactly as in the full campaign: a failed trial again, alone (--only 44,117)");
  a.value("shard", shard,
          "K/N: run only the trials whose index is K modulo N (0 <= K < N), e.g. one task of a Slurm array; "
          "`minimanip merge` joins the shards' folders (--shard 1/4); 0/1: every trial");
  a.value("seed", seed, {0, 9.007e15}, "", "campaign seed; every random choice derives from (seed, trial, purpose)");
  a.choice("hardware", hardware, hardwareNames(), "mujoco: physics; mock: joints follow commands exactly");
  a.path("robot", robot_path, "the arm: its YAML, a URDF (.urdf) or an MJCF file (.xml), each with its companion <file>.yaml when there is one. A path in a file is relative to the file; --set, to the working directory; the default, to the project root");
  a.path("gripper", gripper_path, "gripper YAML mounted on the arm's flange; default: the arm's own (its YAML's gripper:); paths as for robot");
  a.path("scene", scene_path, "scene MJCF, the world only (its static parts may be URDF files it <include>s): the harness mounts the robot at its robot_mount site; paths as for robot");
  a.path("tree", tree_path, "behavior tree (BT.CPP v4 XML) run for each trial; paths as for robot. The default is the source's MiniManip tree");
  a.value("jobs", jobs, {0, 64}, "", "worker processes running trials in parallel, 0: one per core (outcomes do not depend on it)");
  a.value("watchdog", watchdog, {1, 1e6}, "s",
          "wall-clock limit of one trial, raised to 10x the campaign's median trial when that is more: a worker past it is "
          "taken as hung, killed, and its trial retried once in a fresh worker, then recorded as failure_kind hang. It only "
          "catches true hangs; a trial's own limit is its simulated-time budget (bt.time_budget, deterministic)");
  a.choice("progress", progress, {"auto", "bar", "lines", "none"}, "progress display; auto: a bar on a terminal, lines otherwise");
  a.enter("task");
  a.choice("goal", goal, {"pick_one", "clear_bin"},
           "what a trial is asked to do, for the report (the tree decides what the robot does): pick_one, one object placed "
           "(the objects left in the bin are context, not a yield); clear_bin, every object (the per-object yield is the headline)");
  a.leave();
  a.enter("objects");
  spawn.declare(a);
  a.leave();
  a.enter("physics");
  physics.declare(a);
  a.leave();
  a.enter("perception");
  perception.declare(a);
  a.leave();
  task.declare(a);
  a.enter("faults");
  faults.declare(a);
  a.leave();
  a.enter("test_faults");
  a.list("segfault", test_faults.segfault, {0, 1e7},
         "test only: the worker running these trials dereferences a null pointer before the trial, in every attempt "
         "(recorded as failure_kind crash)");
  a.list("segfault_once", test_faults.segfault_once, {0, 1e7},
         "test only: as segfault, in the first attempt only (the retry in a fresh worker succeeds)");
  a.list("hang", test_faults.hang, {0, 1e7}, "test only: the worker running these trials sleeps forever instead (the watchdog's case)");
  a.leave();
  a.enter("bt");
  tree_run.declare(a);
  a.choice("log", bt_log, {"none", "failed_or_recovered", "all"},
           "which trials keep their tree's transitions as results/<name>/bt/trial_<N>.db3 (BT.CPP's SqliteLogger schema, Groot2)");
  a.leave();
  a.enter("render");
  render.declare(a);
  a.leave();
}

RobotModel loadExperimentRobot(const Experiment& e) {
  RobotModel robot = loadAnyRobot(e.robot_path, e.gripper_path == "default" ? "" : e.gripper_path);
  const GripperSpec& g = robot.spec().gripper;
  if (e.task.grasp_force > g.max_force)
  {
    std::ostringstream o;
    o << "grasp.force " << e.task.grasp_force << " N is past the gripper's limit (" << g.max_force << " N, " << g.file << ")";
    throw InputError(e.file, o.str());
  }
  return resolveHome(e, robot);
}

std::vector<ParamDecl> experimentParams() {
  Experiment e;
  return declarationsOf([&](ConfigArchive& a) { e.declare(a); });
}

std::string resolvePath(const std::string& path, const std::string& origin) {
  const std::filesystem::path v = path;
  if (v.is_absolute()) return v.lexically_normal().string();
  if (origin == "(default)") return (std::filesystem::path(MINIMANIP_SOURCE_DIR) / v).lexically_normal().string();
  if (origin.empty()) return v.lexically_normal().string();  // --set: the working directory
  return (std::filesystem::path(origin).parent_path() / v).lexically_normal().string();
}

std::string robotPathFromName(const std::string& name_or_path) {
  if (name_or_path.find('/') != std::string::npos || name_or_path.find('.') != std::string::npos) return name_or_path;
  return (std::filesystem::path(MINIMANIP_SOURCE_DIR) / "robots" / name_or_path / (name_or_path + ".yaml")).string();
}

std::vector<std::vector<std::string>> sweepCells(const std::vector<ParamSet::Sweep>& sweep) {
  std::vector<std::vector<std::string>> cells{{}};
  for (const ParamSet::Sweep& f : sweep) {
    std::vector<std::vector<std::string>> next;
    for (const auto& c : cells)
      for (const std::string& v : f.values) {
        next.push_back(c);
        next.back().push_back(f.key + "=" + v);
      }
    cells = std::move(next);
  }
  return cells;
}

Experiment loadExperiment(const std::string& path, const std::vector<std::string>& sets, const std::vector<std::string>& sweeps,
                          bool file_sweep) {
  Experiment e;
  ParamSet p(experimentParams());
  p.loadYamlFile(path);
  if (!file_sweep) p.clearSweeps();
  for (const std::string& s : sets) {
    const auto eq = s.find('=');
    if (eq == std::string::npos || eq == 0) throw InputError("--set " + s, "expected key=value");
    p.set(s.substr(0, eq), s.substr(eq + 1), "--set " + s.substr(0, eq), "");
  }
  for (const std::string& s : sweeps) {
    const auto eq = s.find('=');
    if (eq == std::string::npos || eq == 0) throw InputError("--sweep " + s, "expected key=value,value,...");
    p.addSweep(s.substr(0, eq), splitCommas(s.substr(eq + 1)), "--sweep " + s.substr(0, eq));
  }
  // Keys that shape the campaign rather than its trials cannot be factors.
  for (const ParamSet::Sweep& f : p.sweeps()) {
    static const std::vector<std::string> fixed = {"name", "trials", "seed", "jobs", "shard", "watchdog", "progress", "bt.log"};
    if (std::find(fixed.begin(), fixed.end(), f.key) != fixed.end() || f.key.rfind("test_faults.", 0) == 0)
      throw InputError(f.where, "'" + f.key + "' cannot be swept (it shapes the campaign, not its trials; seeds are shared by design)");
  }
  {
    double cells = 1;  // counted before any grid is built
    for (const ParamSet::Sweep& f : p.sweeps()) cells *= static_cast<double>(f.values.size());
    if (cells > 256)
      throw InputError(p.sweeps().front().where, "the sweep has " + std::to_string(static_cast<long long>(cells)) +
                                                     " cells, expected at most 256");
  }
  readConfig(p, [&](ConfigArchive& a) { e.declare(a); },
             [&](const std::string& key, const std::string& value) {
               // Names that are not files: the robot's own gripper, the simulator's camera pose.
               const bool name = (key == "gripper" && value == "default") || (key == "perception.extrinsics" && value == "simulator");
               return name ? value : resolvePath(value, p.origin(key));
             });
  e.file = path;
  e.sweep = p.sweeps();
  e.params = std::move(p);
  e.sets = sets;
  // Cross-key checks: a sweep's cells are checked each, with their values (runSweep).
  if (e.sweep.empty() && e.spawn.count_min > e.spawn.count_max)
    throw InputError(path, "objects.count_min (" + std::to_string(e.spawn.count_min) + ") must be <= objects.count_max (" +
                               std::to_string(e.spawn.count_max) + ")");
  for (int64_t t : e.only)
    if (t >= e.trials)
      throw InputError(path, "'only' lists trial " + std::to_string(t) + ", expected indices below trials (" +
                                 std::to_string(e.trials) + ")");
  {
    int k = -1, n = 0;
    char rest = 0;
    if (std::sscanf(e.shard.c_str(), "%d/%d%c", &k, &n, &rest) != 2 || n < 1 || k < 0 || k >= n)
      throw InputError(e.params.origin("shard").empty() ? "--set shard" : e.params.origin("shard"),
                       "shard is '" + e.shard + "', expected K/N with 0 <= K < N, e.g. 0/4");
    e.shard_index = k, e.shard_count = n;
  }
  for (int i = 0; i < static_cast<int>(FaultKind::kCount); ++i) {
    const FaultKind k = static_cast<FaultKind>(i);
    if (faultNeedsCamera(k) && e.faults.rate[static_cast<int>(k)] > 0 && e.perception.mode != PerceptionMode::kCamera)
      throw InputError(e.params.origin(std::string("faults.") + faultKindName(k)).empty() ? path
                                                                                           : e.params.origin(std::string("faults.") + faultKindName(k)),
                       std::string("faults.") + faultKindName(k) + " strikes the camera: it needs perception.mode camera");
  }
  if (e.perception.segmentation == SegmentationSource::kLabels && e.perception.mode != PerceptionMode::kCamera)
    throw InputError(e.params.origin("perception.segmentation").empty() ? path : e.params.origin("perception.segmentation"),
                     "perception.segmentation labels segments the camera's view: it needs perception.mode camera");
  if (500 % e.render.fps != 0)
    throw InputError(path, "render.fps is " + std::to_string(e.render.fps) +
                               ", expected a divisor of the 500 Hz control rate (e.g. 10, 20, 25, 50, 100)");
  e.spawn.physics = e.hardware == "mujoco";
  if (e.jobs == 0) e.jobs = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return e;
}

bool needsCamera(const Experiment& e, const bt::TreeDocument& tree) {
  bool cloud = false;
  for (const auto& [value, where] : tree.attributeValues("WaitForGraspCandidates", "source")) {
    if (value != "" && value != "model" && value != "cloud" && value != "external")
      throw InputError(where, "WaitForGraspCandidates source=\"" + value + "\": expected model, cloud, external or nothing");
    cloud |= value == "cloud" || value == "external";
  }
  return cloud || e.perception.mode == PerceptionMode::kCamera || e.task.grasp_source != TaskOptions::GraspSource::kModel;
}

bool usesExternal(const Experiment& e, const bt::TreeDocument& tree) {
  if (e.task.grasp_source == TaskOptions::GraspSource::kExternal) return true;
  for (const auto& [value, where] : tree.attributeValues("WaitForGraspCandidates", "source"))
    if (value == "external") return true;
  return false;
}

bool needsCamera(const Experiment& e) { return needsCamera(e, loadTree(e)); }

std::string oracleOf(const Experiment& e) {
  if (e.perception.mode == PerceptionMode::kGroundTruth) return "poses";
  if (e.perception.mode == PerceptionMode::kCamera && e.perception.segmentation == SegmentationSource::kLabels) return "segmentation";
  // The external component given the renderer's segmentation (external.oracle).
  return e.task.external.oracle && !e.task.external.argv().empty() ? "segmentation" : "";
}

}  // namespace mm
