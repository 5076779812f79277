// `minimanip gate RESULTS_DIR --thresholds FILE [--baseline FILE_OR_DIR]`: a campaign's results
// judged for CI. Yields against thresholds by their Wilson 95% lower bound; summary values against
// limits; against a baseline run on the same seeds: paired success by McNemar's exact test,
// deterministic work counters (collision checks, root ticks, grasp candidates, simulated time)
// compared exactly, and wall timings trial by trial (the median of the per-trial ratios and the
// Wilcoxon signed-rank test: noise alone must not fail a gate; both a significant and a large
// slowdown do) against a baseline folder run beside this one (tools/timing_gate); a stored baseline
// file holds no timings. Each check states the smallest change its sample could detect. Exit
// codes: 0 pass, 1 regression, 2 bad input.
#pragma once
#include <string>
#include <vector>

#include "core/config.h"
#include "core/params.h"

namespace mm {

/// The thresholds file (experiments/gates/*.yaml), declared once like an experiment's keys.
struct GateThresholds {
  std::string experiment = "any";  ///< the campaign's name it is meant for ("any": every one)
  int64_t min_trials = 1;
  double overall_yield = -1, first_pass_yield = -1, fault_recovery = -1;  ///< Wilson lower bounds (-1: not gated)
  double cycle_time_mean = -1, cycle_time_max = -1, place_position_error_mm_max = -1,
         place_orientation_error_deg_max = -1, collisions_per_100_trials = -1;  ///< upper limits (-1: none)
  int64_t sim_unstable = -1, crashes = -1, hangs = -1, timeouts = -1;          ///< trials at most (-1: any)
  std::string baseline = "none";  ///< a baseline file or results folder ("none": none unless --baseline)
  double alpha = 0.05;      ///< McNemar's test
  std::vector<std::string> counters = {"collision_checks", "ticks", "grasp_candidates_tried", "sim_time"};
  double counter_tolerance = 0;  ///< relative increase of a counter's sum allowed
  std::vector<std::string> timings = {"compute_time"};
  double max_ratio = 1.5;   ///< median wall-time ratio (new / baseline) a regression must exceed
  double timing_alpha = 0.01;
  bool timing_same_cpu = true;  ///< compare wall timings only with a baseline from the same CPU model
  std::vector<std::string> config_may_differ;  ///< experiment keys the baseline's configuration may differ in
  void declare(ConfigArchive& a);
};

/// The keys of a thresholds file (`minimanip gate-doc` prints them for docs/reference/gate.md).
std::vector<ParamDecl> gateParams();
/// Per-trial fields a baseline holds: deterministic counters and wall timings.
std::vector<std::string> gateCounterNames();
std::vector<std::string> gateTimingNames();

struct GateOptions {
  std::string results_dir;
  std::string thresholds;     ///< required unless only saving a baseline
  std::string baseline;       ///< overrides the thresholds' baseline.file
  std::string save_baseline;  ///< write results_dir's baseline file here
};

struct GateResult {
  int exit_code = 0;  ///< 0 pass, 1 regression
  std::string text;   ///< the checks, one per line, for a person
  std::string json;   ///< the same as JSON (also written to RESULTS_DIR/gate.json)
};

/// Judges (and/or saves a baseline). Bad input throws InputError (exit code 2) before any verdict.
GateResult runGate(const GateOptions& options);

}  // namespace mm
