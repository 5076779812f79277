// `minimanip plan-bench`: planners x collision checkers x time parameterizations on the same
// planning problems from the bin scene, in one run. Problems: home -> pre-grasp (the bin's objects
// as obstacles), lift -> pre-place (the object held), retreat -> home; from seeded scenes. The
// "clutter" set adds seeded obstacles to each scene (a divider between bin and tray, an overhead
// bar, posts) so that the direct motion is blocked and the planners have work to do.
// Outputs: plan_bench.json, plan_bench.md and plan_bench.log (OMPL's benchmark log format, which
// ompl_benchmark_statistics.py turns into the database Planner Arena reads).
#pragma once
#include <string>
#include <vector>

#include "core/config.h"

namespace mm {

struct PlanBenchOptions {
  /// Every option of `minimanip plan-bench` (--key value on the command line).
  void declare(ConfigArchive& a);
  std::string robot = "panda";  ///< a name under robots/ or a path (robotPathFromName)
  std::string scene = "scenes/bin_table.xml";
  int scenes = 20;                        ///< seeded bin layouts; 3 problems each
  std::string problems = "bin";           ///< "bin" or "clutter"
  uint64_t seed = 1;
  double time_limit = 5.0;                ///< [s] per planning call
  double padding = 0.01;                  ///< [m]
  std::vector<std::string> planners;      ///< empty: all
  std::vector<std::string> checkers = {"spheres", "spheres+fcl", "fcl"};
  bool simplify = true;
  std::string optimizer = "none";         ///< "chomp": also run each planner followed by CHOMP
  std::string out_dir = "results/plan-bench";
  std::string command_line;
};

/// Runs the benchmark and returns the Markdown report (also written to the output folder).
std::string runPlanBench(const PlanBenchOptions& options);

}  // namespace mm
