// minimanip: command-line entry. Parses arguments and calls the campaign layer; nothing else.
// Exit codes: 0 done, 1 internal error, 2 bad input (nothing run, no results written).
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "campaign/bench.h"
#include "campaign/campaign.h"
#include "campaign/experiment.h"
#include "campaign/ik_bench.h"
#include "campaign/plan_bench.h"
#include "campaign/trial.h"
#include "core/error.h"

namespace {

const char* kUsage =
    "usage:\n"
    "  minimanip run EXPERIMENT.yaml [--trials N] [--seed S] [--out DIR] [--jobs N] [--set key=value]...\n"
    "  minimanip bench EXPERIMENT.yaml [--trials N] [--seed S] [--set key=value]...\n"
    "                                harness throughput vs pure MuJoCo stepping of the same trials\n"
    "  minimanip ik-bench [--robot panda] [--poses 1000] [--seed S] [--budget 5ms] [--solvers a,b]\n"
    "                     [--sets random,bin,singular,limits] [--tip tcp|flange] [--distinct N] [--out DIR]\n"
    "                                every IK solver on the same poses and seeds\n"
    "  minimanip plan-bench [--scenes 20] [--seed S] [--planners a,b] [--checkers spheres,spheres+fcl,fcl]\n"
    "                       [--problems bin|clutter] [--time-limit 5] [--padding 0.01] [--no-simplify]\n"
    "                       [--optimizer chomp] [--out DIR]\n"
    "                                planners x checkers x time parameterizations on bin-scene problems\n"
    "  minimanip config-doc          print every experiment key as a Markdown table\n"
    "  minimanip nodes-doc           print the behavior-tree node library (ports, meanings) as a Markdown table\n"
    "  minimanip help\n";

// The value after the option at args[i] (i moves onto it); an InputError if there is none.
std::string nextValue(const std::vector<std::string>& args, size_t& i) {
  if (i + 1 >= args.size()) throw mm::InputError(args[i], "expected a value after " + args[i]);
  return args[++i];
}

int run(const std::vector<std::string>& args, const std::string& command_line, bool bench) {
  if (args.empty()) throw mm::InputError("minimanip run", std::string("expected an experiment file\n") + kUsage);
  std::string file, out;
  std::vector<std::string> sets;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&] { return nextValue(args, i); };
    if (a == "--trials") sets.push_back("trials=" + value());
    else if (a == "--seed") sets.push_back("seed=" + value());
    else if (a == "--jobs") sets.push_back("jobs=" + value());
    else if (a == "--out") out = value();
    else if (a == "--set") sets.push_back(value());
    else if (a.rfind("--", 0) == 0) throw mm::InputError(a, std::string("unknown option\n") + kUsage);
    else if (file.empty()) file = a;
    else throw mm::InputError(a, "expected one experiment file, got a second argument");
  }
  if (file.empty()) throw mm::InputError("minimanip run", "expected an experiment file");
  const mm::Experiment e = mm::loadExperiment(file, sets);
  if (bench) {
    std::cout << mm::benchmarkHarness(e, command_line);
    return 0;
  }
  mm::CampaignOptions co;
  co.out_dir = out.empty() ? "results/" + e.name : out;
  co.command_line = command_line;
  const std::string table = mm::runCampaign(e, co);
  std::cout << table << "Results: " << co.out_dir << "/ (trials.jsonl, summary.json, config.resolved.yaml)\n";
  return 0;
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

// "5ms", "500us", "0.01s" or a number of seconds.
double parseDuration(const std::string& flag, const std::string& v) {
  size_t end = 0;
  double x = 0;
  try {
    x = std::stod(v, &end);
  } catch (const std::exception&) {
    throw mm::InputError(flag, "expected a duration like 5ms, got '" + v + "'");
  }
  const std::string unit = v.substr(end);
  const double scale = unit == "ms" ? 1e-3 : unit == "us" ? 1e-6 : (unit == "s" || unit.empty()) ? 1.0 : -1.0;
  if (scale < 0 || !(x > 0)) throw mm::InputError(flag, "expected a positive duration like 5ms, got '" + v + "'");
  return x * scale;
}

long parseCount(const std::string& flag, const std::string& v, long lo, long hi) {
  size_t end = 0;
  long x = 0;
  try {
    x = std::stol(v, &end);
  } catch (const std::exception&) {
    end = 0;
  }
  if (end != v.size() || x < lo || x > hi)
    throw mm::InputError(flag, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" + v + "'");
  return x;
}

int ikBench(const std::vector<std::string>& args, const std::string& command_line) {
  mm::IkBenchOptions o;
  o.scene = "scenes/bin_table.xml";
  o.command_line = command_line;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&] { return nextValue(args, i); };
    if (a == "--robot") o.robot = value();
    else if (a == "--poses") o.poses = static_cast<int>(parseCount(a, value(), 1, 10000000));
    else if (a == "--seed") o.seed = static_cast<uint64_t>(parseCount(a, value(), 0, 9007199254740992L));
    else if (a == "--budget") o.budget = parseDuration(a, value());
    else if (a == "--solvers") o.solvers = splitList(value());
    else if (a == "--sets") o.sets = splitList(value());
    else if (a == "--distinct") o.distinct_poses = static_cast<int>(parseCount(a, value(), 0, 1000000));
    else if (a == "--scene") o.scene = value();
    else if (a == "--tip") o.tip = value();
    else if (a == "--out") o.out_dir = value();
    else throw mm::InputError(a, std::string("unknown option\n") + kUsage);
  }
  std::cout << mm::runIkBench(o) << "Results: " << o.out_dir << "/ (ik_bench.json, ik_bench.md)\n";
  return 0;
}

int planBench(const std::vector<std::string>& args, const std::string& command_line) {
  mm::PlanBenchOptions o;
  o.command_line = command_line;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&] { return nextValue(args, i); };
    if (a == "--scenes") o.scenes = static_cast<int>(parseCount(a, value(), 1, 100000));
    else if (a == "--seed") o.seed = static_cast<uint64_t>(parseCount(a, value(), 0, 9007199254740992L));
    else if (a == "--planners") o.planners = splitList(value());
    else if (a == "--checkers") o.checkers = splitList(value());
    else if (a == "--time-limit") o.time_limit = parseDuration(a, value());
    else if (a == "--padding") {
      const std::string v = value();
      char* end = nullptr;
      o.padding = std::strtod(v.c_str(), &end);
      if (!end || *end || !(o.padding >= 0 && o.padding <= 0.1)) throw mm::InputError(a, "expected a padding in [0, 0.1] m, got '" + v + "'");
    } else if (a == "--no-simplify") o.simplify = false;
    else if (a == "--optimizer") o.optimizer = value();
    else if (a == "--problems") {
      o.problems = value();
      if (o.problems != "bin" && o.problems != "clutter") throw mm::InputError(a, "expected bin or clutter, got '" + o.problems + "'");
    } else if (a == "--robot") o.robot = value();
    else if (a == "--scene") o.scene = value();
    else if (a == "--out") o.out_dir = value();
    else throw mm::InputError(a, std::string("unknown option\n") + kUsage);
  }
  std::cout << mm::runPlanBench(o) << "Results: " << o.out_dir << "/ (plan_bench.json, plan_bench.md, plan_bench.log)\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  std::string command_line = "minimanip";
  for (const auto& a : args) command_line += " " + a;
  try {
    if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
      std::cout << kUsage;
      return args.empty() ? 2 : 0;
    }
    if (args[0] == "run") return run({args.begin() + 1, args.end()}, command_line, false);
    if (args[0] == "plan-bench") return planBench({args.begin() + 1, args.end()}, command_line);
    if (args[0] == "ik-bench") return ikBench({args.begin() + 1, args.end()}, command_line);
    if (args[0] == "bench") return run({args.begin() + 1, args.end()}, command_line, true);
    if (args[0] == "config-doc") {
      std::cout << mm::ParamSet(mm::experimentParams()).toMarkdown();
      return 0;
    }
    if (args[0] == "nodes-doc") {
      std::cout << mm::nodeLibraryMarkdown();
      return 0;
    }
    throw mm::InputError(args[0], std::string("unknown command\n") + kUsage);
  } catch (const mm::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "internal error: " << e.what() << "\n";
    return 1;
  }
}
