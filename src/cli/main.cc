// minimanip: command-line entry (CLI11). Parses arguments and calls the campaign layer; nothing
// else. The benches' options come from their declarations (declare()), like the experiment keys.
// Exit codes: 0 done, 1 internal error, 2 bad input (nothing run, no results written) or a results
// folder in use by another process, 3 results that cannot be written (disk full, read-only file
// system, permission denied: the message names the path and the cause).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <csignal>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "bench/calibrate.h"
#include "bench/harness_bench.h"
#include "bench/ik_bench.h"
#include "bench/plan_bench.h"
#include "campaign/campaign.h"
#include "campaign/cell_check.h"
#include "campaign/experiment.h"
#include "campaign/record.h"
#include "campaign/gate.h"
#include "campaign/report.h"
#include "campaign/sweep.h"
#include "campaign/trial.h"
#include "core/config.h"
#include "core/error.h"
#include "core/utf8.h"

namespace {

// `run` and `bench`: an experiment file, a few shortcuts and --set key=value.
struct RunArgs {
  std::string file, out, trials, seed, jobs, only, shard;
  std::vector<std::string> sets, sweeps;
  bool no_sweep = false;
};

void addRunOptions(CLI::App* sub, RunArgs& r, bool with_out) {
  sub->add_option("experiment", r.file, "experiment YAML (every key: minimanip config-doc)")->required();
  sub->add_option("--trials", r.trials, "number of trials (= --set trials=N)");
  sub->add_option("--seed", r.seed, "campaign seed (= --set seed=S)");
  sub->add_option("--jobs", r.jobs, "parallel workers (= --set jobs=N)");
  sub->add_option("--only", r.only, "only these trials, e.g. 44,117 (= --set only=44,117)");
  sub->add_option("--shard", r.shard, "K/N: only the trials with index % N == K (= --set shard=K/N)");
  if (with_out) sub->add_option("--out", r.out, "results folder (default results/<name>)");
  sub->add_option("--set", r.sets, "key=value, any experiment key (repeatable)")->allow_extra_args(false);
  if (with_out)
    sub->add_option("--sweep", r.sweeps, "key=a,b,c: run the campaign for each value (repeatable: the grid of all); = the file's sweep: map")
        ->allow_extra_args(false);
  if (with_out)
    sub->add_flag("--no-sweep", r.no_sweep, "ignore the file's sweep: map (replay one cell with --set key=value)");
}

mm::Experiment loadRun(const RunArgs& r) {
  std::vector<std::string> sets;
  if (!r.trials.empty()) sets.push_back("trials=" + r.trials);
  if (!r.seed.empty()) sets.push_back("seed=" + r.seed);
  if (!r.jobs.empty()) sets.push_back("jobs=" + r.jobs);
  if (!r.only.empty()) sets.push_back("only=" + r.only);
  if (!r.shard.empty()) sets.push_back("shard=" + r.shard);
  sets.insert(sets.end(), r.sets.begin(), r.sets.end());
  return mm::loadExperiment(r.file, sets, r.sweeps, !r.no_sweep);
}

// A subcommand whose options are a struct's declarations: --key value (underscores as dashes).
struct Declared {
  std::vector<mm::ParamDecl> decls;
  std::map<std::string, std::pair<CLI::Option*, std::string>> given;  // key -> option, text

  void add(CLI::App* sub, std::vector<mm::ParamDecl> d) {
    decls = std::move(d);
    for (const mm::ParamDecl& p : decls) {
      std::string flag = p.key;
      for (char& c : flag)
        if (c == '_' || c == '.') c = '-';
      auto& slot = given[p.key];
      std::string help = p.help + (p.unit.empty() ? "" : " [" + p.unit + "]") + " (default: " +
                         (p.default_value.empty() ? "none" : p.default_value) + ")";
      if (!p.choices.empty()) {
        help += "; one of";
        for (const auto& c : p.choices) help += " " + c;
      }
      slot.first = sub->add_option("--" + flag, slot.second, help);
    }
  }
  // The struct filled through `declare` from the defaults and the options given; paths given
  // resolve against the working directory, defaults against the project root.
  void read(const std::function<void(mm::ConfigArchive&)>& declare) const {
    mm::ParamSet p(decls);
    for (const auto& [key, slot] : given)
      if (slot.first->count() > 0) p.set(key, slot.second, slot.first->get_name(), "");
    mm::readConfig(p, declare, [&](const std::string& key, const std::string& v) { return mm::resolvePath(v, p.origin(key)); });
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string command_line = "minimanip";
  for (int i = 1; i < argc; ++i) command_line += std::string(" ") + argv[i];

  CLI::App app{"Mini-Manip Bench: pick-and-place campaigns and benchmarks in MuJoCo"};
  app.require_subcommand(1);
  app.fallthrough(false);

  RunArgs run_args, bench_args;
  CLI::App* run = app.add_subcommand("run", "an N-trial campaign: trials.jsonl, summary.json, config.resolved.yaml, bt/*.db3");
  addRunOptions(run, run_args, true);
  CLI::App* bench = app.add_subcommand("bench", "harness benchmark: each trial through the tree, through the tree-less "
                                                 "chain and as bare MuJoCo stepping");
  addRunOptions(bench, bench_args, false);
  RunArgs check_args;
  CLI::App* check = app.add_subcommand("check", "every check a run makes before its first trial, and a dry run of the cell: how the "
                                                 "robot's files were read (flange, TCP, home, IK solver), home clear of the scene, the "
                                                 "gripper's reach over the bin and the place target, the camera seeing the bin; "
                                                 "exit 0 (weak figures are warnings), 2 bad input");
  addRunOptions(check, check_args, false);

  mm::IkBenchOptions ik;
  ik.scene = "scenes/bin_table.xml";
  Declared ik_decl;
  CLI::App* ik_cmd = app.add_subcommand("ik-bench", "every IK solver on the same poses and seeds");
  ik_decl.add(ik_cmd, mm::declarationsOf([&](mm::ConfigArchive& a) { ik.declare(a); }));

  mm::PlanBenchOptions plan;
  Declared plan_decl;
  CLI::App* plan_cmd = app.add_subcommand("plan-bench", "planners x checkers x time parameterizations on the same problems");
  plan_decl.add(plan_cmd, mm::declarationsOf([&](mm::ConfigArchive& a) { plan.declare(a); }));
  bool no_simplify = false;
  plan_cmd->add_flag("--no-simplify", no_simplify, "do not simplify the planned paths (= --simplify false)");

  std::vector<std::string> merge_dirs;
  std::string merge_out;
  CLI::App* merge = app.add_subcommand("merge", "join the results folders of a campaign's shards (--shard K/N) into one");
  merge->add_option("folders", merge_dirs, "the shards' results folders")->required();
  merge->add_option("--out", merge_out, "the merged results folder (new or empty)")->required();

  mm::ReportOptions report_opts;
  CLI::App* report = app.add_subcommand("report", "a campaign's results as report.html (self-contained, plots inline) and report.md");
  report->add_option("results", report_opts.results_dir, "the campaign's results folder")->required();
  report->add_option("--ik-bench", report_opts.ik_bench, "also an ik-bench results folder (ik_bench.json)");
  report->add_option("--plan-bench", report_opts.plan_bench, "also a plan-bench results folder (plan_bench.json)");

  mm::GateOptions gate_opts;
  CLI::App* gate = app.add_subcommand("gate", "judge a campaign for CI: yields (Wilson lower bounds), limits, and against a baseline "
                                              "paired success (McNemar), exact work counters and, against a results folder run beside it, wall timings trial by trial "
                                              "(median ratio + Wilcoxon signed-rank; tools/timing_gate); "
                                              "exit 0 pass, 1 regression, 2 bad input");
  gate->add_option("results", gate_opts.results_dir, "the campaign's results folder")->required();
  gate->add_option("--thresholds", gate_opts.thresholds, "thresholds file (experiments/gates/*.yaml; keys: minimanip gate-doc)");
  gate->add_option("--baseline", gate_opts.baseline, "a baseline file or results folder (overrides the thresholds' baseline.file)");
  gate->add_option("--save-baseline", gate_opts.save_baseline, "write the results' baseline file (per-trial success and work counters: its deterministic fields)");

  std::string render_dir;
  uint64_t render_trial = 0;
  std::vector<std::string> render_sets;
  CLI::App* render = app.add_subcommand("render", "a campaign's trial run again from its seed with images and video "
                                                   "(results/<name>/replays/trial_<N>/, emptied first), checked against its line in trials.jsonl");
  render->add_option("results", render_dir, "the campaign's results folder")->required();
  render->add_option("--trial", render_trial, "the trial to render")->required();
  render->add_option("--set", render_sets, "render.KEY=VALUE: what to render (default: every stage's key frame "
                                           "in rgb, depth and segmentation with previews, and the video)");

  mm::DatasetOptions dataset_opts;
  CLI::App* dataset = app.add_subcommand("dataset", "a campaign's camera views, its trials run again from their seeds, as a BOP dataset "
                                                     "(rgb, depth, masks, the objects' true poses and models; docs/datasets.md)");
  dataset->add_option("results", dataset_opts.results_dir, "the campaign's results folder (camera mode)")->required();
  dataset->add_option("--out", dataset_opts.out_dir, "the dataset's folder (default: RESULTS/bop; replaced if it holds a dataset)");
  dataset->add_option("--split", dataset_opts.split, "the images' folder in the dataset")->capture_default_str();
  dataset->add_option("--trial", dataset_opts.trials, "only these trials (default: every trial, in order)");
  dataset->add_option("--views", dataset_opts.max_views, "stop after this many views (0: all)")->capture_default_str();

  std::string calib_experiment = "experiments/camera.yaml";
  std::vector<std::string> calib_sets;
  mm::CalibrateOptions calib;
  CLI::App* calibrate = app.add_subcommand("calibrate", "hand-eye calibration in simulation: eye-to-hand (the perception camera, a "
                                                         "ChArUco board on the gripper) and eye-in-hand (the wrist camera, the board on the table), "
                                                         "OpenCV's five methods, without and with image noise");
  calibrate->add_option("experiment", calib_experiment, "the experiment whose robot, scene and perception camera to calibrate")->capture_default_str();
  calibrate->add_option("--views", calib.views, "poses per mounting (at least 15)")->capture_default_str();
  calibrate->add_option("--seed", calib.seed, "seed of the poses and the image noise")->capture_default_str();
  calibrate->add_option("--noise", calib.pixel_noise, "std of the Gaussian image noise of the noisy runs [grey levels]")->capture_default_str();
  calibrate->add_option("--out", calib.out_dir, "results folder (calibration.md, calibration.json, <camera>_extrinsics.yaml)")->capture_default_str();
  calibrate->add_option("--set", calib_sets, "KEY=VALUE: an experiment key");

  // The worker process of a campaign (started by `run`, not by people): hidden from --help.
  RunArgs worker_args;
  CLI::App* worker = app.add_subcommand("worker", "");
  worker->group("");
  worker->add_option("experiment", worker_args.file)->required();
  worker->add_option("--out", worker_args.out)->required();
  worker->add_option("--set", worker_args.sets);

  CLI::App* config_doc = app.add_subcommand("config-doc", "print every experiment key as a Markdown table");
  CLI::App* nodes_doc = app.add_subcommand("nodes-doc", "print the behavior-tree node library as a Markdown table");
  CLI::App* results_doc = app.add_subcommand("results-doc", "print the fields of trials.jsonl and summary.json as Markdown");
  CLI::App* gate_doc = app.add_subcommand("gate-doc", "print every key of a gate's thresholds file as a Markdown table");

  try {
    // Every argument is text that may reach a record (paths, --set values): UTF-8 is checked
    // here, where it enters, naming the option it belongs to.
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      const std::string option = i > 1 && argv[i - 1][0] == '-' && arg[0] != '-' ? std::string(argv[i - 1]) : "argument " + std::to_string(i);
      mm::requireUtf8(arg, option, "'" + mm::escapeInvalidUtf8(arg.size() > 60 ? arg.substr(0, 60) + "..." : arg) + "'");
    }
    const std::vector<std::string> commands = {"run", "check", "bench", "render", "dataset", "calibrate", "ik-bench", "plan-bench", "config-doc", "nodes-doc", "results-doc", "merge", "report", "gate", "gate-doc", "worker"};
    if (argc > 1 && argv[1][0] != '-' && std::find(commands.begin(), commands.end(), argv[1]) == commands.end())
      throw mm::InputError(argv[1], "unknown command (expected run, check, bench, render, dataset, calibrate, merge, report, gate, ik-bench, plan-bench, config-doc, nodes-doc, results-doc or gate-doc; --help)");
    try {
      app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
      return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
      return app.exit(e);
    } catch (const CLI::ParseError& e) {
      throw mm::InputError("minimanip", std::string(e.what()) + "\n" + app.help());
    }
    if (report->parsed()) {
      std::cout << "Report: " << mm::writeReport(report_opts) << " (and report.md, report_figures/)\n";
      return 0;
    }
    if (gate->parsed()) {
      const mm::GateResult g = mm::runGate(gate_opts);
      std::cout << g.text;
      return g.exit_code;
    }
    if (calibrate->parsed()) {
      calib.command_line = command_line;
      std::cout << mm::runCalibration(mm::loadExperiment(calib_experiment, calib_sets, {}, false), calib)
                << "Results: " << calib.out_dir << "/ (calibration.md, calibration.json, <camera>_extrinsics.yaml)\n";
      return 0;
    }
    if (render->parsed()) {
      for (const std::string& kv : render_sets)
        if (kv.rfind("render.", 0) != 0)
          throw mm::InputError("--set " + kv, "expected a render.KEY=VALUE setting (the trial itself is the campaign's)");
      signal(SIGPIPE, SIG_IGN);  // a video encoder that dies is reported, not a signal
      const mm::RenderReplay r = mm::renderTrial(render_dir, render_trial, render_sets);
      std::cout << "Rendered trial " << render_trial << " with " << r.renderer << ":\n";
      for (const std::string& f : r.files) std::cout << "  " << r.dir << "/" << f << "\n";
      if (r.matches) {
        std::cout << "Replay matches trial " << render_trial << " in trials.jsonl (every outcome field).\n";
        return 0;
      }
      std::cout << "Replay DIFFERS from trial " << render_trial << " in trials.jsonl:\n";
      for (const std::string& d : r.differences) std::cout << "  " << d << "\n";
      return 1;
    }
    if (dataset->parsed()) {
      const mm::DatasetWritten d = mm::writeDataset(dataset_opts);
      std::cout << "Dataset: " << d.dir << "/ (BOP format: " << d.scenes << " scenes, " << d.views << " views, " << d.models
                << " object models; rendered with " << d.renderer << ")\n";
      if (d.differing.empty()) {
        std::cout << "Every trial run again matches its line in trials.jsonl.\n";
        return 0;
      }
      std::cout << "Trials run again that DIFFER from trials.jsonl (their views are not the campaign's):";
      for (uint64_t t : d.differing) std::cout << " " << t;
      std::cout << "\n";
      return 1;
    }
    if (gate_doc->parsed()) {
      std::cout << mm::ParamSet(mm::gateParams()).toMarkdown();
      return 0;
    }
    if (merge->parsed()) {
      std::cout << mm::mergeResults(merge_dirs, merge_out, command_line) << "Results: " << merge_out
                << "/ (trials.jsonl, summary.json, campaign.json, config.resolved.yaml, bt/)\n";
      return 0;
    }
    if (worker->parsed()) return mm::runWorker(mm::loadExperiment(worker_args.file, worker_args.sets, {}, false), worker_args.out);
    if (check->parsed()) {
      const mm::CellCheck c = mm::checkCell(loadRun(check_args));
      std::cout << c.text << (c.warnings ? std::to_string(c.warnings) + " warning(s)\n" : std::string("all clear\n"));
      return 0;
    }
    if (run->parsed() || bench->parsed()) {
      const RunArgs& r = run->parsed() ? run_args : bench_args;
      const mm::Experiment e = loadRun(r);
      if (bench->parsed()) {
        if (!e.sweep.empty()) throw mm::InputError(e.sweep.front().where, "bench does not sweep (run a sweep with minimanip run)");
        std::cout << mm::benchmarkHarness(e, command_line);
        return 0;
      }
      mm::CampaignOptions co;
      co.out_dir = r.out.empty() ? "results/" + e.name : r.out;
      co.command_line = command_line;
      if (!e.sweep.empty()) {
        const std::string table = mm::runSweep(e, co);
        std::cout << table << "Results: " << co.out_dir << "/ (sweep.json, cell_<i>/: each a campaign's results folder)\n";
        return 0;
      }
      const std::string table = mm::runCampaign(e, co);
      std::cout << table << "Results: " << co.out_dir << "/ (trials.jsonl, summary.json, campaign.json, config.resolved.yaml, bt/)\n";
      return 0;
    }
    if (ik_cmd->parsed()) {
      ik_decl.read([&](mm::ConfigArchive& a) { ik.declare(a); });
      ik.command_line = command_line;
      std::cout << mm::runIkBench(ik) << "Results: " << ik.out_dir << "/ (ik_bench.json, ik_bench.md)\n";
      return 0;
    }
    if (plan_cmd->parsed()) {
      plan_decl.read([&](mm::ConfigArchive& a) { plan.declare(a); });
      if (no_simplify) plan.simplify = false;
      plan.command_line = command_line;
      std::cout << mm::runPlanBench(plan) << "Results: " << plan.out_dir << "/ (plan_bench.json, plan_bench.md, plan_bench.log)\n";
      return 0;
    }
    if (config_doc->parsed()) {
      std::cout << mm::ParamSet(mm::experimentParams()).toMarkdown();
      return 0;
    }
    if (nodes_doc->parsed()) {
      std::cout << mm::nodeLibraryMarkdown();
      return 0;
    }
    if (results_doc->parsed()) {
      std::cout << mm::recordsMarkdown();
      return 0;
    }
    return 2;
  } catch (const mm::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const mm::OutputError& e) {
    std::cerr << "error: " << e.what() << " (what was written before is complete: once that is mended, the same command resumes)\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "internal error: " << e.what() << "\n";
    return 1;
  }
}
