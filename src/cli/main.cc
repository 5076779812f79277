// minimanip: command-line entry. Parses arguments and calls the campaign layer; nothing else.
// Exit codes: 0 done, 1 internal error, 2 bad input (nothing run, no results written).
#include <iostream>
#include <string>
#include <vector>

#include "campaign/bench.h"
#include "campaign/campaign.h"
#include "campaign/experiment.h"
#include "core/error.h"

namespace {

const char* kUsage =
    "usage:\n"
    "  minimanip run EXPERIMENT.yaml [--trials N] [--seed S] [--out DIR] [--jobs N] [--set key=value]...\n"
    "  minimanip bench EXPERIMENT.yaml [--trials N] [--seed S] [--set key=value]...\n"
    "                                harness throughput vs pure MuJoCo stepping of the same trials\n"
    "  minimanip config-doc          print every experiment key as a Markdown table\n"
    "  minimanip help\n";

int run(const std::vector<std::string>& args, const std::string& command_line, bool bench) {
  if (args.empty()) throw mm::InputError("minimanip run", std::string("expected an experiment file\n") + kUsage);
  std::string file, out;
  std::vector<std::string> sets;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= args.size()) throw mm::InputError(a, "expected a value after " + a);
      return args[++i];
    };
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
    if (args[0] == "bench") return run({args.begin() + 1, args.end()}, command_line, true);
    if (args[0] == "config-doc") {
      std::cout << mm::ParamSet(mm::experimentParams()).toMarkdown();
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
