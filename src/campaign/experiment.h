// An experiment: every parameter of a campaign, declared once (key, type, default, range, unit,
// meaning) in experiment.cc. Loaded from YAML plus --set overrides; unknown keys are errors.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/params.h"
#include "perception/perception.h"
#include "sim/scene_sampler.h"
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
  std::string robot_path;  ///< resolved against the experiment file's folder
  std::string scene_path;
  int jobs = 1;
  std::string progress;    ///< "auto" | "bar" | "lines" | "none"
  SpawnOptions spawn;
  PerceptionOptions perception;
  TaskOptions task;
  ParamSet params{experimentParams()};  ///< every value as used (for config.resolved.yaml)
};

/// Loads `path`, applies `sets` ("key=value"), validates. Throws InputError (exit code 2).
Experiment loadExperiment(const std::string& path, const std::vector<std::string>& sets);

}  // namespace mm
