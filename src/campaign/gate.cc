#include "campaign/gate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "campaign/experiment.h"
#include "campaign/record.h"
#include "campaign/stats.h"
#include "core/error.h"
#include "core/file_io.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr int kBaselineFormat = 1;

// ---- what a trial contributes --------------------------------------------------------------------

double counterOf(const TrialOutcome& o, const std::string& name) {
  if (name == "collision_checks") return static_cast<double>(o.collision_checks);
  if (name == "ticks") return static_cast<double>(o.ticks);
  if (name == "grasp_candidates_tried") return o.grasp_candidates_tried;
  if (name == "pushes") return o.pushes;
  if (name == "sim_time") return o.sim_time;
  if (name == "execute_pick_time") return o.execute_pick_time;
  if (name == "execute_place_time") return o.execute_place_time;
  throw std::logic_error("unknown counter " + name);
}

double timingOf(const TrialOutcome& o, const std::string& name) {
  if (name == "compute_time") return o.compute_time;
  if (name == "perception_time") return o.perception_time;
  if (name == "plan_pick_time") return o.plan_pick_time;
  if (name == "plan_place_time") return o.plan_place_time;
  throw std::logic_error("unknown timing " + name);
}

struct Sample {
  bool success = false;
  std::map<std::string, double> counters, timings;
};

/// A campaign as the gate sees it: from a results folder, or from a baseline file made of one.
struct Run {
  std::string source;  ///< the folder or file, for messages
  std::string experiment, cpu, command;
  unsigned long seed = 0;
  json config;  ///< the campaign's configuration fingerprint (campaign.json); null when not recorded
  std::map<unsigned long, Sample> trials;  ///< by trial index
};

json readJson(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw InputError(p.string(), "cannot be read (expected a JSON file)");
  try {
    return json::parse(in);
  } catch (const std::exception& e) {
    throw InputError(p.string(), std::string("not JSON: ") + e.what());
  }
}

Run readResults(const fs::path& dir, json* summary_out) {
  if (!fs::is_directory(dir)) throw InputError(dir.string(), "not a results folder");
  const fs::path summary_path = dir / "summary.json", jsonl = dir / "trials.jsonl";
  const json s = readJson(summary_path);
  Run r;
  r.source = dir.string();
  try {
    r.experiment = s.at("experiment").get<std::string>();
    r.seed = s.at("seed").get<unsigned long>();
    r.command = s.value("command", "");
    r.cpu = s.at("environment").value("cpu", "");
  } catch (const std::exception& e) {
    throw InputError(summary_path.string(), std::string("not a campaign summary: ") + e.what());
  }
  if (fs::exists(dir / "campaign.json")) {
    const json meta = readJson(dir / "campaign.json");
    if (meta.is_object() && meta.contains("fingerprint") && meta.at("fingerprint").is_object()) r.config = meta.at("fingerprint");
  }
  std::ifstream in(jsonl);
  if (!in) throw InputError(jsonl.string(), "cannot be read");
  std::string line;
  for (long n = 1; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    const std::string where = jsonl.string() + ":" + std::to_string(n);
    Sample x;
    unsigned long index = 0;
    const json j = json::parse(line, nullptr, false);
    if (j.is_object() && j.contains("schema") && j["schema"].is_number_integer() && j["schema"].get<int>() != kTrialSchema) {
      // A record of another build (tools/timing_gate's base is the previous commit, which may
      // write another schema): only the gate's own fields, by name (top level, or the cycle's).
      auto named = [&](const std::string& key) -> const json& {
        if (j.contains(key)) return j[key];
        if (j.contains("cycle") && j["cycle"].is_object() && j["cycle"].contains(key)) return j["cycle"][key];
        throw InputError(where, "a record of schema " + j["schema"].dump() + " without '" + key + "', which the gate compares");
      };
      try {
        index = named("trial").get<unsigned long>();
        x.success = named("success").get<bool>();
        for (const std::string& c : gateCounterNames()) x.counters[c] = named(c).get<double>();
        for (const std::string& c : gateTimingNames()) x.timings[c] = named(c).get<double>();
      } catch (const json::exception& e) {
        throw InputError(where, std::string("a record of schema ") + j["schema"].dump() + ": " + e.what());
      }
    } else {
      const TrialRecord t = fromJsonLine(line, where);
      index = t.trial;
      x.success = t.o.success;
      for (const std::string& c : gateCounterNames()) x.counters[c] = counterOf(t.o, c);
      for (const std::string& c : gateTimingNames()) x.timings[c] = timingOf(t.o, c);
    }
    if (!r.trials.emplace(index, x).second) throw InputError(where, "trial " + std::to_string(index) + " appears twice");
  }
  if (r.trials.empty()) throw InputError(jsonl.string(), "holds no trial");
  if (summary_out) *summary_out = s;
  return r;
}

json baselineJson(const Run& r) {
  json trials = json::array();
  // Deterministic fields only: wall timings measured on another day, under another load, are no
  // baseline for today's (tools/timing_gate compares timings side by side, in one job).
  for (const auto& [i, x] : r.trials) trials.push_back({{"trial", i}, {"success", x.success}, {"counters", x.counters}});
  return {{"minimanip_gate_baseline", kBaselineFormat}, {"experiment", r.experiment}, {"seed", r.seed},
          {"command", r.command}, {"cpu", r.cpu}, {"config", r.config}, {"trials", trials}};
}

Run readBaselineFile(const fs::path& p) {
  const json j = readJson(p);
  Run r;
  r.source = p.string();
  try {
    if (j.at("minimanip_gate_baseline").get<int>() != kBaselineFormat)
      throw InputError(p.string(), "baseline format " + j.at("minimanip_gate_baseline").dump() + ", expected " +
                                       std::to_string(kBaselineFormat) + " (make it again with --save-baseline)");
    r.experiment = j.at("experiment").get<std::string>();
    r.seed = j.at("seed").get<unsigned long>();
    r.command = j.value("command", "");
    r.cpu = j.value("cpu", "");
    if (j.contains("config") && j.at("config").is_object()) r.config = j.at("config");
    for (const json& t : j.at("trials")) {
      Sample x;
      x.success = t.at("success").get<bool>();
      for (const std::string& c : gateCounterNames()) x.counters[c] = t.at("counters").at(c).get<double>();
      // Timings an older baseline file holds are not read (see baselineJson).
      const unsigned long index = t.at("trial").get<unsigned long>();
      if (!r.trials.emplace(index, x).second)
        throw InputError(p.string(), "trial " + std::to_string(index) + " appears twice");
    }
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(p.string(), std::string("not a gate baseline (minimanip gate --save-baseline): ") + e.what());
  }
  if (r.trials.empty()) throw InputError(p.string(), "holds no trial");
  return r;
}

Run readBaseline(const fs::path& p) {
  if (fs::is_directory(p)) return readResults(p, nullptr);
  if (!fs::exists(p)) throw InputError(p.string(), "not found (expected a baseline file or a results folder)");
  return readBaselineFile(p);
}

// ---- checks --------------------------------------------------------------------------------------

struct Check {
  std::string name, verdict;  ///< verdict: pass, fail or skip
  std::string detail;         ///< the numbers
  std::string detects;        ///< the smallest change this sample could detect
};

std::string fmt(double v, int precision = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", precision, v);
  return buf;
}

std::string fmtg(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

/// The largest count k of n whose Wilson lower bound is below `threshold`: observed yields of k/n
/// or fewer fail the gate.
long largestFailingCount(long n, double threshold) {
  long k = -1;
  for (long i = 0; i <= n; ++i)
    if (wilson95(i, n).first < threshold) k = i;
  return k;
}

Check yieldCheck(const std::string& name, long k, long n, double threshold) {
  Check c;
  c.name = name;
  const double lo = wilson95(k, n).first;
  c.verdict = lo >= threshold ? "pass" : "fail";
  c.detail = std::to_string(k) + "/" + std::to_string(n) + " = " + fmt(100.0 * k / n, 1) + "%, Wilson 95% lower bound " +
             fmt(100 * lo, 1) + "% " + (lo >= threshold ? ">=" : "<") + " threshold " + fmt(100 * threshold, 1) + "%";
  const long kf = largestFailingCount(n, threshold);
  if (kf < 0)
    c.detects = "nothing: even 0/" + std::to_string(n) + " passes a threshold of " + fmt(100 * threshold, 1) + "%";
  else if (kf >= n)
    c.detects = "none: with " + std::to_string(n) + " trials even " + std::to_string(n) + "/" + std::to_string(n) +
                " has a lower bound below the threshold (more trials needed)";
  else
    c.detects = "fails at " + std::to_string(kf) + "/" + std::to_string(n) + " (" + fmt(100.0 * kf / n, 1) + "%) or fewer";
  return c;
}

Check limitCheck(const std::string& name, double value, double limit, const std::string& unit) {
  Check c;
  c.name = name;
  c.verdict = value <= limit ? "pass" : "fail";
  c.detail = fmtg(value) + unit + (value <= limit ? " <= " : " > ") + "limit " + fmtg(limit) + unit;
  c.detects = "any value above the limit";
  return c;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0 : n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

void requireChoices(const std::vector<std::string>& got, const std::vector<std::string>& allowed, const std::string& where) {
  for (const std::string& g : got)
    if (std::find(allowed.begin(), allowed.end(), g) == allowed.end()) {
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw InputError(where, "'" + g + "' is not one of " + list);
    }
}


/// The keys whose values differ between two configuration fingerprints, but those `allowed` and the
/// test-only planner slowdown (it stands in for a slower build); "" when they agree. A key the
/// baseline does not have (declared after it was made) agrees when the run leaves it at its default:
/// a new option's default keeps the old behaviour.
std::string configDifferences(const json& base, const json& run, const std::vector<std::string>& allowed) {
  std::set<std::string> keys;
  for (const auto& [k, v] : base.items()) keys.insert(k);
  for (const auto& [k, v] : run.items()) keys.insert(k);
  std::map<std::string, std::string> defaults;
  for (const ParamDecl& d : experimentParams()) defaults[d.key] = d.default_value;
  std::string said;
  int n = 0;
  for (const std::string& k : keys) {
    if (k == "planning.test_slowdown" || k == "planning.test_time_factor" || std::find(allowed.begin(), allowed.end(), k) != allowed.end()) continue;
    if (!base.contains(k) && run.contains(k) && run.at(k).is_string() && defaults.count(k) &&
        run.at(k).get<std::string>() == defaults.at(k))
      continue;
    const json a = base.contains(k) ? base.at(k) : json("(absent)"), b = run.contains(k) ? run.at(k) : json("(absent)");
    if (a == b) continue;
    if (n++ == 6) {
      said += "; ...";
      break;
    }
    said += (said.empty() ? "" : "; ") + k + " " + a.dump() + " there, " + b.dump() + " here";
  }
  return said;
}

}  // namespace

void GateThresholds::declare(ConfigArchive& a) {
  a.value("experiment", experiment, "the campaign name these thresholds are for (its summary's experiment); any: every campaign");
  a.value("min_trials", min_trials, {1, 1e9}, "", "fewest trials a campaign must have to be judged (fewer: exit 2)");
  a.enter("yields");
  a.value("overall_yield", overall_yield, {-1, 1}, "",
          "the overall yield's Wilson 95% lower bound must reach this (-1: not gated)");
  a.value("first_pass_yield", first_pass_yield, {-1, 1}, "", "the first-pass yield's, likewise");
  a.value("fault_recovery", fault_recovery, {-1, 1}, "",
          "each injected fault kind's recovery (summary faults[].recovery), likewise; kinds with nothing to judge are skipped");
  a.leave();
  a.enter("limits");
  a.value("cycle_time_mean", cycle_time_mean, {-1, 1e6}, "s", "mean cycle time over successes at most (-1: none)");
  a.value("cycle_time_max", cycle_time_max, {-1, 1e6}, "s", "longest cycle time at most (-1: none)");
  a.value("place_position_error_mm_max", place_position_error_mm_max, {-1, 1e6}, "mm", "worst place position error at most (-1: none)");
  a.value("place_orientation_error_deg_max", place_orientation_error_deg_max, {-1, 1e6}, "deg",
          "worst place orientation error at most (-1: none)");
  a.value("collisions_per_100_trials", collisions_per_100_trials, {-1, 1e6}, "", "collision episodes per 100 trials at most (-1: none)");
  a.value("sim_unstable", sim_unstable, {-1, 1e9}, "", "trials MuJoCo flagged unstable at most (-1: any)");
  a.value("crashes", crashes, {-1, 1e9}, "", "trials whose worker crashed twice at most (-1: any)");
  a.value("hangs", hangs, {-1, 1e9}, "", "trials the watchdog stopped twice at most (-1: any)");
  a.value("timeouts", timeouts, {-1, 1e9}, "", "trials past their simulated-time budget at most (-1: any)");
  a.leave();
  a.enter("baseline");
  a.path("file", baseline,
         "a baseline file (minimanip gate --save-baseline) or a results folder of the same experiment and seed; relative to "
         "this file; --baseline overrides; none: no baseline checks");
  a.value("alpha", alpha, {1e-6, 0.5}, "", "McNemar's exact test of paired success: a loss of successes this unlikely under no change fails");
  a.list("counters", counters, gateCounterNames(),
         "deterministic per-trial counters whose sum over the trials both runs hold may not grow (exact: no noise to allow for)");
  a.value("counter_tolerance", counter_tolerance, {0, 10}, "", "relative growth of a counter's sum allowed (0: none)");
  a.list("timings", timings, gateTimingNames(),
         "per-trial wall timings, each trial against the same trial of the baseline: the median of their ratios and the Wilcoxon signed-rank test (both must show a slowdown)");
  a.value("max_ratio", max_ratio, {1, 100}, "", "the median of a timing's per-trial ratios (this run / baseline) above this, and significant, fails");
  a.value("timing_alpha", timing_alpha, {1e-9, 0.5}, "", "the Wilcoxon signed-rank test's two-sided significance level for timings");
  a.value("timing_same_cpu", timing_same_cpu, "compare wall timings only with a baseline from the same CPU model (else skipped, said so)");
  a.list("config_may_differ", config_may_differ, {},
         "experiment keys (and robot, scene, tree: their files) the baseline's configuration may differ in; any other "
         "difference is exit 2 (a baseline of another configuration compares nothing); a baseline recording none is not checked");
  a.leave();
}

std::vector<ParamDecl> gateParams() {
  GateThresholds t;
  return declarationsOf([&](ConfigArchive& a) { t.declare(a); });
}

std::vector<std::string> gateCounterNames() {
  return {"collision_checks", "ticks", "grasp_candidates_tried", "pushes", "sim_time", "execute_pick_time", "execute_place_time"};
}

std::vector<std::string> gateTimingNames() { return {"compute_time", "perception_time", "plan_pick_time", "plan_place_time"}; }

GateResult runGate(const GateOptions& o) {
  const fs::path dir = o.results_dir;
  json summary;
  const Run run = readResults(dir, &summary);
  GateResult result;
  if (!o.save_baseline.empty()) {
    writeFileAtomically(o.save_baseline, baselineJson(run).dump(1) + "\n");
    result.text = "Baseline of " + std::to_string(run.trials.size()) + " trials written to " + o.save_baseline + "\n";
    if (o.thresholds.empty()) return result;
  }
  if (o.thresholds.empty()) throw InputError("minimanip gate", "--thresholds FILE is required (or --save-baseline FILE)");

  // The thresholds, validated before any verdict.
  GateThresholds t;
  ParamSet p(gateParams());
  p.loadYamlFile(o.thresholds);
  if (!p.sweeps().empty()) throw InputError(p.sweeps().front().where, "a thresholds file has no sweep: map");
  readConfig(p, [&](ConfigArchive& a) { t.declare(a); },
             [&](const std::string& key, const std::string& value) {
               return value == "none" ? std::string() : resolvePath(value, p.origin(key));
             });
  requireChoices(t.counters, gateCounterNames(), o.thresholds + ": baseline.counters");
  requireChoices(t.timings, gateTimingNames(), o.thresholds + ": baseline.timings");
  {
    std::vector<std::string> keys = {"robot", "scene", "tree"};
    for (const ParamDecl& d : experimentParams()) keys.push_back(d.key);
    requireChoices(t.config_may_differ, keys, o.thresholds + ": baseline.config_may_differ");
  }
  const std::string baseline_path = !o.baseline.empty() ? o.baseline : t.baseline;
  if (t.experiment != "any" && t.experiment != run.experiment)
    throw InputError(o.thresholds, "thresholds for experiment '" + t.experiment + "', but " + dir.string() + " ran '" +
                                       run.experiment + "'");
  if (!summary.contains("trials") || !summary.at("trials").is_number_integer())
    throw InputError((dir / "summary.json").string(), "no integer 'trials' (not a campaign summary)");
  const long n = summary.at("trials").get<long>();
  if (n < t.min_trials)
    throw InputError(dir.string(), std::to_string(n) + " trials, the thresholds (" + o.thresholds + ") need at least " +
                                       std::to_string(t.min_trials));
  Run base;
  if (!baseline_path.empty()) {
    base = readBaseline(baseline_path);
    if (base.seed != run.seed)
      throw InputError(baseline_path, "seed " + std::to_string(base.seed) + ", but " + dir.string() + " ran seed " +
                                          std::to_string(run.seed) + " (paired comparisons need the same seeds)");
    if (base.experiment != run.experiment)
      throw InputError(baseline_path, "experiment '" + base.experiment + "', but " + dir.string() + " ran '" + run.experiment + "'");
    if (!base.config.is_null() && !run.config.is_null()) {
      const std::string diff = configDifferences(base.config, run.config, t.config_may_differ);
      if (!diff.empty())
        throw InputError(baseline_path, "another configuration than " + dir.string() + ": " + diff +
                                            " (make a new baseline, or list the keys in baseline.config_may_differ)");
    }
  }

  std::vector<Check> checks;
  try {
    // Yields by their Wilson lower bounds.
    const long successes = summary.at("successes").get<long>();
    if (t.overall_yield >= 0) checks.push_back(yieldCheck("overall_yield", successes, n, t.overall_yield));
    if (t.first_pass_yield >= 0) {
      const long k = std::lround(summary.at("first_pass_yield").at("value").get<double>() * n);
      checks.push_back(yieldCheck("first_pass_yield", k, n, t.first_pass_yield));
    }
    if (t.fault_recovery >= 0)
      for (const json& f : summary.at("faults")) {
        const bool recoverable = f.at("recoverable").get<bool>();
        const long good = f.at(recoverable ? "recovered" : "given_up").get<long>();
        const long judged = good + f.at("unrecovered").get<long>();
        const std::string name = "fault_recovery." + f.at("kind").get<std::string>();
        if (judged == 0) {
          checks.push_back({name, "skip", "nothing to judge (no detected fault of this kind)", ""});
          continue;
        }
        checks.push_back(yieldCheck(name, good, judged, t.fault_recovery));
      }
    // Limits on summary values.
    const auto lim = [&](const std::string& name, double value, double limit, const std::string& unit) {
      if (limit >= 0) checks.push_back(limitCheck(name, value, limit, unit));
    };
    lim("cycle_time.mean", summary.at("cycle_time").at("mean").get<double>(), t.cycle_time_mean, " s");
    lim("cycle_time.max", summary.at("cycle_time").at("max").get<double>(), t.cycle_time_max, " s");
    lim("place_position_error_mm.max", summary.at("place_position_error_mm").at("max").get<double>(), t.place_position_error_mm_max, " mm");
    lim("place_orientation_error_deg.max", summary.at("place_orientation_error_deg").at("max").get<double>(),
        t.place_orientation_error_deg_max, " deg");
    lim("collisions_per_100_trials", summary.at("collisions_per_100_trials").get<double>(), t.collisions_per_100_trials, "");
    lim("sim_unstable", summary.at("sim_unstable").get<double>(), static_cast<double>(t.sim_unstable), "");
    lim("crashes", summary.at("crashes").get<double>(), static_cast<double>(t.crashes), "");
    lim("hangs", summary.at("hangs").get<double>(), static_cast<double>(t.hangs), "");
    lim("timeouts", summary.at("timeouts").get<double>(), static_cast<double>(t.timeouts), "");
  } catch (const nlohmann::json::exception& e) {
    throw InputError((dir / "summary.json").string(), std::string("a field the gate needs is missing: ") + e.what());
  }

  std::string notes;
  if (!baseline_path.empty()) {
    std::vector<unsigned long> common;
    for (const auto& [i, x] : run.trials)
      if (base.trials.count(i)) common.push_back(i);
    if (common.empty())
      throw InputError(baseline_path, "shares no trial index with " + dir.string() + " (expected the same experiment's trials)");
    notes += "baseline " + base.source + ": " + std::to_string(common.size()) + " trials in common (this run " +
             std::to_string(run.trials.size()) + ", baseline " + std::to_string(base.trials.size()) + ")" +
             (base.config.is_null() || run.config.is_null() ? "; no configuration recorded on one side: not compared" : "") + "\n";
    // Paired success: McNemar's exact test on the trials that changed.
    long lost = 0, gained = 0;
    for (unsigned long i : common) {
      const bool b = base.trials.at(i).success, r = run.trials.at(i).success;
      lost += b && !r;
      gained += !b && r;
    }
    {
      Check c;
      c.name = "paired_success";
      const double pv = mcnemarExactP(lost, gained);
      c.verdict = lost > gained && pv < t.alpha ? "fail" : "pass";
      c.detail = std::to_string(lost) + " trials lost, " + std::to_string(gained) + " gained; McNemar exact p = " + fmtg(pv) +
                 (c.verdict == "fail" ? " < " : " (alpha ") + fmtg(t.alpha) + (c.verdict == "fail" ? "" : ")");
      long need = 1;
      while (need <= static_cast<long>(common.size()) && mcnemarExactP(need, 0) >= t.alpha) ++need;
      c.detects = need <= static_cast<long>(common.size())
                      ? std::to_string(need) + " trials lost with none gained (" + fmt(100.0 * need / common.size(), 1) + "% of " +
                            std::to_string(common.size()) + ")"
                      : "none: too few trials in common";
      checks.push_back(c);
    }
    // Deterministic counters: exact sums over the common trials, in trial order.
    for (const std::string& name : t.counters) {
      double sb = 0, sr = 0;
      long differ = 0;
      for (unsigned long i : common) {
        const double b = base.trials.at(i).counters.at(name), r = run.trials.at(i).counters.at(name);
        sb += b, sr += r;
        differ += b != r;
      }
      Check c;
      c.name = "counter." + name;
      const bool grew = sr > sb * (1 + t.counter_tolerance);
      c.verdict = grew ? "fail" : "pass";
      c.detail = "sum " + fmtg(sr) + " vs baseline " + fmtg(sb) + (sb != 0 ? " (" + fmt(100 * (sr / sb - 1), 2) + "%)" : "") + ", " +
                 std::to_string(differ) + " of " + std::to_string(common.size()) + " trials differ" +
                 (!grew && sr < sb ? " (fewer: make a new baseline to keep the gain)" : "");
      c.detects = t.counter_tolerance > 0 ? "growth above " + fmt(100 * t.counter_tolerance, 2) + "%" : "any growth (exact)";
      checks.push_back(c);
    }
    // Wall timings, trial by trial: the median ratio and the signed-rank test, both needed to fail.
    const bool same_cpu = base.cpu == run.cpu;
    for (const std::string& name : t.timings) {
      Check c;
      c.name = "timing." + name;
      // The same trials on both sides: each trial's ratio, so that what differs between trials
      // (one needs a long detour, the next none) cancels and only the builds' difference is left.
      std::vector<double> log_ratio;
      const bool timed = !base.trials.empty() && !base.trials.begin()->second.timings.empty();
      for (unsigned long i : timed ? common : std::vector<unsigned long>{}) {
        const double b = base.trials.at(i).timings.at(name), r = run.trials.at(i).timings.at(name);
        if (b > 0 && r > 0) log_ratio.push_back(std::log(r / b));
      }
      if (!timed) {
        c.verdict = "skip";
        c.detail = "the baseline " + base.source + " is a stored file, which holds no wall timings (tools/timing_gate compares "
                   "timings side by side, the base run beside this one)";
      } else if (t.timing_same_cpu && !same_cpu) {
        c.verdict = "skip";
        c.detail = "baseline ran on '" + base.cpu + "', this run on '" + run.cpu + "' (timing_same_cpu)";
      } else if (log_ratio.size() < 8) {
        c.verdict = "skip";
        c.detail = "fewer than 8 trials timed on both sides (" + std::to_string(log_ratio.size()) + ")";
      } else {
        const SignedRank w = wilcoxonSignedRank(log_ratio);
        const double ratio = std::exp(median(log_ratio));
        const bool slower = ratio > t.max_ratio && w.p < t.timing_alpha;
        c.verdict = slower ? "fail" : "pass";
        c.detail = "median of the " + std::to_string(log_ratio.size()) + " trials' ratios (this run / baseline) " + fmt(ratio, 3) +
                   " (limit " + fmt(t.max_ratio, 2) + "), Wilcoxon signed-rank p = " + fmtg(w.p) + " (alpha " + fmtg(t.timing_alpha) + ")";
        double mean = 0, ss = 0;
        for (double x : log_ratio) mean += x / static_cast<double>(log_ratio.size());
        for (double x : log_ratio) ss += (x - mean) * (x - mean);
        const double sd = std::sqrt(ss / static_cast<double>(log_ratio.size() - 1));
        const double mdr = minimumDetectablePairedRatio(static_cast<long>(log_ratio.size()), sd, t.timing_alpha);
        // Failing needs both: the observed ratio past the limit (a true ratio R is seen above the
        // limit with probability 0.8 when log R = log limit + z_0.8 se) and the test significant
        // (R >= mdr). The larger of the two is what this sample detects at 80% power.
        const double se = sd / std::sqrt(static_cast<double>(log_ratio.size()));
        const double at_limit = t.max_ratio * std::exp(0.8416212335729143 * se);
        c.detects = "a slowdown of " + fmt(std::max(mdr, at_limit), 2) + "x at 80% power (the limit " + fmt(t.max_ratio, 2) +
                    "x plus this sample's noise; the test alone resolves " + fmt(mdr, 2) + "x)";
      }
      checks.push_back(c);
    }
  }

  json j = json::array();
  std::ostringstream text;
  long failed = 0;
  text << "Gate " << dir.string() << " (" << run.experiment << ", seed " << run.seed << ", " << n << " trials) against "
       << o.thresholds << "\n";
  if (!notes.empty()) text << notes;
  for (const Check& c : checks) {
    failed += c.verdict == "fail";
    std::string upper = c.verdict;
    std::transform(upper.begin(), upper.end(), upper.begin(), ::toupper);
    text << "  " << upper << "  " << c.name << ": " << c.detail << "\n";
    if (!c.detects.empty()) text << "        detects: " << c.detects << "\n";
    j.push_back({{"check", c.name}, {"verdict", c.verdict}, {"detail", c.detail}, {"detects", c.detects}});
  }
  result.exit_code = failed ? 1 : 0;
  text << (failed ? "REGRESSION: " + std::to_string(failed) + " of " + std::to_string(checks.size()) + " checks failed"
                  : "PASS: " + std::to_string(checks.size()) + " checks")
       << " (exit " << result.exit_code << ")\n";
  result.text += text.str();
  const json out = {{"results", dir.string()}, {"thresholds", o.thresholds}, {"baseline", baseline_path},
                    {"exit_code", result.exit_code}, {"checks", j}};
  result.json = out.dump(2) + "\n";
  // The verdict stands whether or not its record can be written (a read-only results folder).
  try {
    writeFileAtomically(dir / "gate.json", result.json);
  } catch (const OutputError& e) {
    result.text += std::string("warning: gate.json not written: ") + e.what() + "\n";
  }
  return result;
}

}  // namespace mm
