// `minimanip ik-bench`: every IK solver on exactly the same target poses and seeds in one run.
// Pose sets: "random" (FK of uniform random configurations), "bin" (grasp, pre-grasp and place
// poses of the quickstart bin scene), "singular" (near the shoulder, elbow and wrist
// singularities), "limits" (one to three joints within 2% of a limit). Seeds at joint mid-range.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/config.h"

namespace mm {

struct IkBenchOptions {
  /// Every option of `minimanip ik-bench` (--key value on the command line).
  void declare(ConfigArchive& a);
  std::string robot = "panda";          ///< a name under robots/ or a path to a robot YAML
  std::string scene;                    ///< scene MJCF for the "bin" set
  std::string tip = "tcp";              ///< "tcp" or "flange": the frame the poses are for
  int poses = 1000;                     ///< per set
  uint64_t seed = 1;
  double budget = 0.005;                ///< [s] wall-clock cap per solve
  std::vector<std::string> solvers;     ///< empty: all
  std::vector<std::string> sets = {"random", "bin", "singular", "limits"};
  int distinct_poses = 100;             ///< poses of the random set asked for up to 8 solutions
  std::string out_dir = "results/ik-bench";
  std::string command_line;
};

/// Runs the benchmark, writes <out>/ik_bench.json and <out>/ik_bench.md, returns the Markdown.
std::string runIkBench(const IkBenchOptions& options);

}  // namespace mm
