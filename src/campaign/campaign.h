// A campaign: N seeded trials of the bin-picking pipeline, results written as they happen.
//   <out>/campaign.json         what the results depend on (resume checks it), the start date
//   <out>/config.resolved.yaml  every parameter as used
//   <out>/trials.jsonl          one JSON object per trial, appended and flushed as each ends
//   <out>/summary.json          yields with Wilson 95% intervals, cycle time, breakdown, accuracy,
//                               failures by stage, environment (written by temp file + rename)
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "campaign/experiment.h"

namespace mm {

struct CampaignOptions {
  std::string out_dir;       ///< results folder
  std::string command_line;  ///< as typed, recorded in the summary
  std::string worker_binary;  ///< the minimanip executable run as workers (default: this process's)
};

/// Loads the robot, the scene and the tree as a campaign would and checks the experiment against
/// them (an object count the scene cannot hold, ...): bad input throws InputError. Returns the
/// robot as loaded, in lines for the user: its flange and home and how each was chosen, and what
/// was changed of its files.
std::string checkCampaignInput(const Experiment& experiment);
/// Those lines, for a robot loaded.
std::string robotAsLoaded(const RobotModel& robot);

/// Loads the robot and scene (input errors throw InputError before anything is written), then
/// runs the trials in `jobs` worker processes (`minimanip worker`) and writes the summary. A
/// results folder that holds the same campaign (campaign.json) is resumed: its finished trials are
/// kept, the others run. A worker that dies or hangs is replaced and its trial retried once, then
/// recorded as failure_kind crash or hang. Returns the printed summary table.
std::string runCampaign(const Experiment& experiment, const CampaignOptions& options);

/// Joins the results folders of one campaign's shards (`--shard K/N`) into `out_dir` (new or
/// empty): checks that they hold the same configuration and trial count, every trial exactly once
/// and no half-written line (InputError before anything is written), then writes trials.jsonl,
/// the tree logs, campaign.json, config.resolved.yaml and the summary recomputed from the trials
/// (wall_seconds: the shards' sum). Returns the printed summary table.
std::string mergeResults(const std::vector<std::string>& dirs, const std::string& out_dir, const std::string& command);

/// A trial rendered again (`minimanip render`).
struct RenderReplay {
  std::string dir;                       ///< its renders folder
  std::vector<std::string> files;        ///< written there
  std::string renderer;
  bool matches = false;                  ///< its outcome equals its line in trials.jsonl
  std::vector<std::string> differences;  ///< otherwise, the first fields that differ
};
/// Runs trial `trial` of the campaign in `results_dir` again from its seed, in this process, with
/// rendering on (key frames of every image kind and a video, unless `render_sets`, "render.key=value",
/// say otherwise), into results_dir/renders/trial_<N>/, and compares its outcome fields with the
/// trial's line in trials.jsonl. InputError when the folder, the trial or the experiment (changed
/// since) does not allow a replay.
RenderReplay renderTrial(const std::string& results_dir, uint64_t trial, const std::vector<std::string>& render_sets);

/// `minimanip dataset`: a campaign's camera views as a BOP dataset (render/bop_writer.h).
struct DatasetOptions {
  std::string results_dir;      ///< the campaign's results folder
  std::string out_dir;          ///< empty: results_dir/bop
  std::string split = "train";  ///< the images' folder in the dataset
  std::vector<uint64_t> trials; ///< empty: every trial the campaign recorded, in order
  int max_views = 0;            ///< stop after this many views (0: all)
};
struct DatasetWritten {
  std::string dir, renderer;
  int scenes = 0, views = 0, models = 0;
  std::vector<uint64_t> differing;  ///< trials whose run again differed from their line in trials.jsonl
};
/// Runs the trials again from their seeds in this process (an external component's recorded
/// answers read, not asked) and writes every image the robot's camera took, with the objects'
/// true poses, masks and models, into a new (or previously written) dataset folder: one BOP scene
/// per trial. InputError when the folder does not allow a replay, when the campaign's robot takes
/// no camera image, or when the output folder holds something else.
DatasetWritten writeDataset(const DatasetOptions& options);

/// The summary table `run` prints.
struct CampaignSummary;
std::string summaryTable(const CampaignSummary& summary);

/// The worker process (the hidden `minimanip worker` command): loads the experiment as the
/// supervisor did, then runs the trials it is sent on stdin and answers each with its trials.jsonl
/// line on stdout. Returns the exit code.
int runWorker(const Experiment& experiment, const std::string& out_dir);

}  // namespace mm
