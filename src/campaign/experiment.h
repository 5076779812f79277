// An experiment: every parameter of a campaign, declared once next to the struct it fills
// (Experiment::declare and the options structs' declare()). Loaded from YAML plus --set overrides;
// unknown keys are errors.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "bt/trial_runner.h"
#include "faults/faults.h"
#include "core/config.h"
#include "core/params.h"
#include "perception/perception.h"
#include "render/trial_renders.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"
#include "task/pick_place.h"

namespace mm {

namespace bt {
class TreeDocument;
}

struct Experiment {
  std::string file;  ///< the YAML it came from
  std::string name = "quickstart";
  int64_t trials = 100;
  std::vector<int64_t> only;  ///< run only these trial indices (each exactly as in the full campaign)
  std::string shard = "0/1";  ///< "K/N": only the trials with index % N == K (0/1: all)
  int shard_index = 0, shard_count = 1;
  uint64_t seed = 1;
  std::string hardware = "mujoco";  ///< see hardwareNames()
  /// What the task asks of a trial (reporting only: the tree decides what the robot does):
  /// pick_one (one object placed a trial; objects left are context) or clear_bin (every object:
  /// the per-object yield is the headline).
  std::string goal = "pick_one";
  /// Paths, resolved: set in the file, against its folder; by --set, against the working
  /// directory; left default, against the project root.
  std::string robot_path = "robots/panda/panda.yaml";
  std::string gripper_path = "default";  ///< "default": the robot's own gripper
  std::string scene_path = "scenes/bin_table.xml";
  std::string tree_path = "experiments/trees/mini_manip.xml";
  int jobs = 0;  ///< 0: one per core
  /// [s] wall clock: a trial running longer (and longer than 10x the campaign's median) is hung.
  double watchdog = 300;
  std::string progress = "auto";  ///< "auto" | "bar" | "lines" | "none"
  std::string bt_log = "failed_or_recovered";  ///< "none" | "failed_or_recovered" | "all": trials that keep a .db3
  SpawnOptions spawn;
  PhysicsOptions physics;
  PerceptionOptions perception;
  TaskOptions task;
  bt::TreeRunOptions tree_run;
  FaultOptions faults;
  RenderOptions render;
  /// Test-only faults of the harness itself, by trial index: the worker process segfaults (in every
  /// attempt, or only the first) or hangs before running the trial.
  struct TestFaults {
    std::vector<int64_t> segfault, segfault_once, hang;
  } test_faults;
  ParamSet params{{}};  ///< every value as used (for config.resolved.yaml)
  std::vector<std::string> sets;  ///< the "key=value" overrides it was loaded with (worker processes load the same)
  /// The factors of a sweep (the file's `sweep:` map, then --sweep key=a,b,c): the campaign runs
  /// once per cell of their grid, on the same seed, each cell a results folder of its own.
  std::vector<ParamSet::Sweep> sweep;

  /// Every key of an experiment file, in the order of the config reference.
  void declare(ConfigArchive& a);
};

/// The declarations (also printed by `minimanip config-doc` for docs/reference/config.md).
std::vector<ParamDecl> experimentParams();
/// The experiment's robot with its gripper and its home in the cell (campaign/robot_home.h);
/// throws InputError when the grasp force is past the gripper's limit or the home will not do.
RobotModel loadExperimentRobot(const Experiment& e);

/// Loads `path`, applies `sets` ("key=value") and `sweeps` ("key=a,b,c", added to the file's
/// sweep unless `file_sweep` is false: then the file's sweep: map is ignored, as for one cell of it),
/// validates. Throws InputError (exit code 2).
Experiment loadExperiment(const std::string& path, const std::vector<std::string>& sets,
                          const std::vector<std::string>& sweeps = {}, bool file_sweep = true);

/// Whether the trials read the perception camera's images: camera perception, or grasps from its
/// points or from an external component given its view (grasp.source: cloud or external, or a
/// WaitForGraspCandidates of the tree with that source). Such a campaign needs an offscreen OpenGL
/// context. The first form loads the experiment's tree.
bool needsCamera(const Experiment& e);
bool needsCamera(const Experiment& e, const bt::TreeDocument& tree);
/// Whether the trials ask the external component (grasp.source: external, or a
/// WaitForGraspCandidates source="external" of the tree).
bool usesExternal(const Experiment& e, const bt::TreeDocument& tree);

/// What the trials are given that no real cell has, for every trial record to say: "poses" (the
/// simulator's poses of the objects, perception.mode: ground_truth), "segmentation" (camera
/// mode's points cut by the renderer's per-object labels, perception.segmentation: labels; or the
/// external component given them, external.oracle), or
/// empty (camera mode from the depth; a hardcoded pose from the configuration).
std::string oracleOf(const Experiment& e);

/// A sweep's cells: every combination of its factors' values (the first factor varies slowest),
/// each as the "key=value" settings that make it.
std::vector<std::vector<std::string>> sweepCells(const std::vector<ParamSet::Sweep>& sweep);

/// A relative path as the configuration resolves it: against the folder of the file that set it,
/// the working directory when set by --set (origin ""), the project root when left default.
std::string resolvePath(const std::string& path, const std::string& origin);

/// A robot named on a benchmark's command line: a bare name ("panda", "ur5e") is the project's
/// robots/<name>/<name>.yaml; anything else is a path (an arm YAML, URDF or MJCF file).
std::string robotPathFromName(const std::string& name_or_path);

}  // namespace mm
