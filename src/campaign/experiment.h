// An experiment: every parameter of a campaign, declared once (key, type, default, range, unit,
// meaning) in experiment.cc. Loaded from YAML plus --set overrides; unknown keys are errors.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/params.h"
#include "perception/perception.h"
#include "sim/scene_sampler.h"
#include "bt/trial_runner.h"
#include "task/pick_place.h"

namespace mm {

/// The declarations (also printed by `minimanip config-doc` for the README).
std::vector<ParamDecl> experimentParams();

struct Experiment {
  std::string file;        ///< the YAML it came from
  std::string name;
  int64_t trials = 0;
  uint64_t seed = 0;
  std::string hardware;    ///< "mujoco" | "mock"
  std::string robot_path;  ///< resolved: set in the file, against its folder; by --set, against the
  std::string scene_path;  ///< working directory; left default, against the project root
  std::string tree_path;   ///< the behavior tree (XML), resolved the same way
  int jobs = 1;
  std::string progress;    ///< "auto" | "bar" | "lines" | "none"
  SpawnOptions spawn;
  PerceptionOptions perception;
  TaskOptions task;
  bt::TreeRunOptions tree_run;
  std::string bt_log;      ///< "none" | "failed_or_recovered" | "all": trials that keep a .db3
  ParamSet params{experimentParams()};  ///< every value as used (for config.resolved.yaml)
};

/// Loads `path`, applies `sets` ("key=value"), validates. Throws InputError (exit code 2).
Experiment loadExperiment(const std::string& path, const std::vector<std::string>& sets);

}  // namespace mm
