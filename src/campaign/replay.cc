// A campaign's trials run again from their seeds and compared with their lines in trials.jsonl:
// `minimanip render` (one trial with images and video, into a folder of its own) and `minimanip
// dataset` (the camera views of its trials as a BOP dataset).
#include "campaign/campaign.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <map>
#include <set>

#include "campaign/record.h"
#include "campaign/results_folder.h"
#include "campaign/trial.h"
#include "campaign/worker.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/folder_lock.h"
#include "render/bop_writer.h"
#include "render/renderer.h"
#include "sim/sim_world.h"

namespace mm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

/// A trials.jsonl object without what wall-clock time decides (compute times, the cycle's totals
/// that include them, the external component's and the pose estimation's times, worker attempts, log paths): what a replay
/// must reproduce exactly.
json outcomeFields(json j) {
  for (const char* k : {"compute_time", "attempts", "bt_log"}) j.erase(k);
  if (j.contains("cycle"))
    for (const char* k : {"perception_time", "plan_pick_time", "plan_place_time", "return_home_time", "total_time"}) j["cycle"].erase(k);
  if (j.contains("stages"))
    for (json& st : j["stages"]) st.erase("compute_seconds");
  if (j.contains("external_calls"))
    for (json& c : j["external_calls"])
      for (const char* k : {"write_seconds", "answer_seconds"}) c.erase(k);
  if (j.contains("pose_views"))
    for (json& v : j["pose_views"]) v.erase("seconds");
  return j;
}

void listDifferences(const json& a, const json& b, const std::string& at, std::vector<std::string>& out) {
  if (out.size() >= 8) return;
  if (a.is_object() && b.is_object()) {
    std::set<std::string> keys;
    for (const auto& [k, v] : a.items()) keys.insert(k);
    for (const auto& [k, v] : b.items()) keys.insert(k);
    for (const std::string& k : keys)
      listDifferences(a.contains(k) ? a[k] : json(), b.contains(k) ? b[k] : json(), at.empty() ? k : at + "." + k, out);
  } else if (a.is_array() && b.is_array() && a.size() == b.size()) {
    for (size_t i = 0; i < a.size(); ++i) listDifferences(a[i], b[i], at + "[" + std::to_string(i) + "]", out);
  } else if (a != b) {
    out.push_back(at + ": " + a.dump() + " recorded, " + b.dump() + " replayed");
  }
}

// A campaign's results folder read for running its trials again: campaign.json, the trials' lines
// and the experiment as the campaign loaded it (paths given by --set resolve against its working
// directory) with `extra` settings after the campaign's; InputError when the folder or the
// experiment (changed since) does not allow it.
struct CampaignAgain {
  fs::path dir;
  json meta;
  std::map<uint64_t, json> lines;  ///< trial -> its line in trials.jsonl
  Experiment e;
};

CampaignAgain loadCampaignAgain(const std::string& results_dir, const std::vector<std::string>& extra) {
  CampaignAgain c;
  c.dir = results_dir;
  const fs::path meta_path = c.dir / "campaign.json";
  if (!fs::exists(meta_path)) throw InputError(results_dir, "no campaign.json: not a campaign's results folder");
  try {
    c.meta = json::parse(std::ifstream(meta_path));
  } catch (const json::exception& ex) {
    throw InputError(meta_path.string(), std::string("not JSON: ") + ex.what());
  }
  if (!c.meta.contains("replay"))
    throw InputError(meta_path.string(), "no 'replay' entry (written by minimanip run since renders exist): run the campaign again to replay it");
  {
    std::ifstream in(c.dir / "trials.jsonl");
    for (std::string line; std::getline(in, line);) {
      const json j = json::parse(line, nullptr, false);
      if (!j.is_discarded() && j.contains("trial") && j["trial"].is_number_unsigned()) c.lines[j["trial"].get<uint64_t>()] = j;
    }
  }
  std::vector<std::string> sets = c.meta["replay"].value("sets", std::vector<std::string>{});
  sets.insert(sets.end(), extra.begin(), extra.end());
  const fs::path here = fs::current_path();
  try {
    fs::current_path(c.meta["replay"].value("cwd", here.string()));
    c.e = loadExperiment(c.meta["replay"].value("experiment", ""), sets, {}, false);
    fs::current_path(here);
  } catch (...) {
    fs::current_path(here);
    throw;
  }
  const json fingerprint = fingerprintOf(c.e);
  if (c.meta.contains("fingerprint") && c.meta["fingerprint"] != fingerprint)
    throw InputError(c.e.file, "the experiment is not the campaign's any more (" + differences(c.meta["fingerprint"], fingerprint, "then", "now") +
                                   "): a replay would not be the same trial");
  return c;
}

// Trial `trial` of campaign `c` run again by `runner` (an external component answering from the
// trial's record, not asked again): where its outcome differs from its line (empty: it matches).
std::vector<std::string> runAgain(const CampaignAgain& c, uint64_t trial, const RobotModel& robot, const Cell& cell, SimWorld& world,
                                  TrialRunner& runner) {
  const json& recorded = c.lines.at(trial);
  runner.replayExternal(fromJsonLine(recorded.dump(), (c.dir / "trials.jsonl").string()).o.external_calls);
  TrialRecord r = runOneTrial(c.e, robot, cell, world, runner, trial, c.dir);
  std::vector<std::string> differences;
  listDifferences(outcomeFields(recorded), outcomeFields(json::parse(toJsonLine(r))), "", differences);
  return differences;
}

}  // namespace

RenderReplay renderTrial(const std::string& results_dir, uint64_t trial, const std::vector<std::string>& render_sets) {
  // What to render: every image and a video unless render_sets say otherwise.
  std::vector<std::string> sets;
  for (const char* d : {"render.keyframes=perception,close_gripper,lift,place,open_gripper_release,end",
                        "render.images=rgb,depth,segmentation", "render.video=true", "render.previews=true"})
    sets.push_back(d);
  sets.insert(sets.end(), render_sets.begin(), render_sets.end());
  sets.push_back("render.trials=" + std::to_string(trial));
  const CampaignAgain c = loadCampaignAgain(results_dir, sets);
  const fs::path& dir = c.dir;
  if (!c.lines.count(trial))
    throw InputError((dir / "trials.jsonl").string(), "no line for trial " + std::to_string(trial) + " (expected a trial this campaign ran)");
  const Experiment& e = c.e;
  const RobotModel robot = loadExperimentRobot(e);
  auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);
  const bt::TreeDocument tree = loadTree(e);
  // A folder of its own, emptied first: the campaign's renders/ stay the campaign's, and two
  // replays' frames never mix. One replay of a trial at a time.
  const fs::path renders = dir / "replays";
  const fs::path trial_dir = trialRenderDir(renders.string(), trial);
  const FolderLock lock(trial_dir, "minimanip render");
  for (const auto& f : fs::directory_iterator(trial_dir))
    if (f.path().filename() != FolderLock::kFileName) fs::remove_all(f.path());
  TrialRunner runner(e, cell, tree, trial_dir.string(), c.meta.value("date", "2000-01-01 00:00:00"));
  RenderSetup setup = setUpRendering(e);
  if (!setup.renderer) throw std::runtime_error("no renderer on this machine (see the message above)");
  runner.setRenderer(setup.renderer.get(), renders.string(), setup.options);
  RenderReplay out;
  out.differences = runAgain(c, trial, robot, cell, *world, runner);
  out.dir = trialRenderDir(renders.string(), trial);
  out.files = runner.rendered();
  out.renderer = setup.renderer->description();
  out.matches = out.differences.empty();
  return out;
}

DatasetWritten writeDataset(const DatasetOptions& o) {
  CampaignAgain c = loadCampaignAgain(o.results_dir, {});
  Experiment& e = c.e;
  e.bt_log = "none";  // the trials' logs are the campaign's
  const bt::TreeDocument tree = loadTree(e);
  if (!needsCamera(e, tree))
    throw InputError((c.dir / "config.resolved.yaml").string(),
                     "the campaign's robot takes no camera image (perception.mode is not camera and no external component): "
                     "a dataset is the views it saw; run the campaign with --set perception.mode=camera");
  if (o.split.empty() || o.split.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") != std::string::npos)
    throw InputError("--split " + o.split, "expected a folder name (letters, digits, _ and -), e.g. train or test");
  std::vector<uint64_t> trials = o.trials;
  if (trials.empty())
    for (const auto& [t, line] : c.lines) trials.push_back(t);
  for (uint64_t t : trials)
    if (!c.lines.count(t))
      throw InputError((c.dir / "trials.jsonl").string(), "no line for trial " + std::to_string(t) + " (expected a trial this campaign ran)");
  if (o.split == "models") throw InputError("--split models", "the dataset's models folder: expected another name, e.g. train or test");
  if (o.max_views < 0) throw InputError("--views " + std::to_string(o.max_views), "expected 0 (all) or more");
  for (size_t i = 0; i < trials.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (trials[i] == trials[j]) throw InputError("--trial " + std::to_string(trials[i]), "given twice: a trial is one scene");
  DatasetWritten out;
  out.dir = o.out_dir.empty() ? (c.dir / "bop").string() : o.out_dir;
  // A folder of its own: new, empty, or a dataset this command wrote before (its marker file; it is
  // replaced). Anything else is refused before anything is touched.
  const fs::path root(out.dir);
  const char* kMarker = "minimanip_dataset.json";
  if (fs::exists(root) && !fs::is_directory(root)) throw InputError(out.dir, "is a file: expected a folder for the dataset (--out)");
  if (fs::exists(root) && !fs::exists(root / kMarker))
    for (const auto& f : fs::directory_iterator(root))
      if (f.path().filename() != FolderLock::kFileName)
        throw InputError(out.dir, std::string("holds files of something else (no ") + kMarker +
                                      " of a dataset written before): expected a new or empty folder (--out)");
  const RobotModel robot = loadExperimentRobot(e);
  auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);
  RenderSetup setup = setUpRendering(e);
  if (!setup.renderer) throw std::runtime_error("no renderer on this machine (see the message above)");
  out.renderer = setup.renderer->description();
  const FolderLock lock(root, "minimanip dataset");
  for (const auto& f : fs::directory_iterator(root))
    if (f.path().filename() != FolderLock::kFileName) fs::remove_all(f.path());
  writeFileAtomically(root / kMarker, json{{"written_by", "minimanip dataset"},
                                           {"results", fs::absolute(c.dir).lexically_normal().string()},
                                           {"split", o.split},
                                           {"format", "BOP (bop_toolkit docs/bop_datasets_format.md)"}}.dump(2));
  BopWriter writer(root, o.split);
  for (const std::string& k : cell.spawn.kinds)
    if (const ObjectKind* kind = cell.spawn.loaded.find(k); kind && kind->solid && kind->symmetries.size() > 1)
      writer.declareSymmetries(kind->solid->pieces, kind->symmetries);
  TrialRunner runner(e, cell, tree, root.string(), c.meta.value("date", "2000-01-01 00:00:00"));
  runner.setRenderer(setup.renderer.get(), (root / "renders").string(), RenderOptions{});
  Renderer& renderer = *setup.renderer;
  // The tap runs inside the trial: what it cannot write stops the dataset after that trial.
  std::string cannot_write;
  runner.setViewTap([&](const SimWorld& w, const Frame& view) {
    if (!cannot_write.empty() || (o.max_views > 0 && writer.views() >= o.max_views)) return;
    try {
      writer.addView(renderer, w, view);
    } catch (const std::exception& ex) {
      cannot_write = ex.what();
    }
  });
  for (uint64_t t : trials) {
    if (o.max_views > 0 && writer.views() >= o.max_views) break;
    writer.beginScene(t);
    const bool differs = !runAgain(c, t, robot, cell, *world, runner).empty();
    if (!cannot_write.empty()) throw OutputError(out.dir, cannot_write);
    if (differs) out.differing.push_back(t);
  }
  writer.finish();
  out.scenes = writer.scenes();
  out.views = writer.views();
  out.models = writer.models();
  return out;
}

}  // namespace mm
