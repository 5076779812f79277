// `minimanip report RESULTS_DIR`: a campaign's results as one self-contained HTML page (plots as
// inline SVG, no script or file fetched at view time) and its Markdown twin (the same tables, the
// plots as SVG files beside it): yields with Wilson intervals, the cycle-time histogram, the stage
// time breakdown, failure stages, the place errors on the tray, recovery per fault kind, and — when
// given — the ik-bench and plan-bench comparisons; each with its command, seed, machine and versions.
#pragma once
#include <string>

namespace mm {

struct ReportOptions {
  std::string results_dir;  ///< a campaign's results folder (summary.json, trials.jsonl)
  std::string ik_bench;     ///< an ik-bench results folder (ik_bench.json), optional
  std::string plan_bench;   ///< a plan-bench results folder (plan_bench.json), optional
};

/// Writes results_dir/report.html, report.md and report_figures/*.svg; returns the HTML's path.
/// Missing or malformed inputs throw InputError (exit code 2) before anything is written.
std::string writeReport(const ReportOptions& options);

}  // namespace mm
