// `minimanip render`: a campaign's trial run again from its seed, with images and video, into a
// folder of its own, and compared with its line in trials.jsonl.
#include "campaign/campaign.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "campaign/record.h"
#include "campaign/results_folder.h"
#include "campaign/trial.h"
#include "campaign/worker.h"
#include "core/error.h"
#include "core/folder_lock.h"
#include "render/renderer.h"
#include "sim/sim_world.h"

namespace mm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

/// A trials.jsonl object without what wall-clock time decides (compute times, the cycle's totals
/// that include them, the external component's times, worker attempts, log paths): what a replay
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

}  // namespace

RenderReplay renderTrial(const std::string& results_dir, uint64_t trial, const std::vector<std::string>& render_sets) {
  const fs::path dir(results_dir);
  const fs::path meta_path = dir / "campaign.json";
  if (!fs::exists(meta_path)) throw InputError(results_dir, "no campaign.json: not a campaign's results folder");
  json meta;
  try {
    meta = json::parse(std::ifstream(meta_path));
  } catch (const json::exception& ex) {
    throw InputError(meta_path.string(), std::string("not JSON: ") + ex.what());
  }
  if (!meta.contains("replay"))
    throw InputError(meta_path.string(), "no 'replay' entry (written by minimanip run since renders exist): run the campaign again to replay it");
  // The trial's recorded line.
  json recorded;
  {
    std::ifstream in(dir / "trials.jsonl");
    for (std::string line; std::getline(in, line);) {
      const json j = json::parse(line, nullptr, false);
      if (!j.is_discarded() && j.value("trial", static_cast<uint64_t>(-1)) == trial) recorded = j;
    }
  }
  if (recorded.is_null())
    throw InputError((dir / "trials.jsonl").string(), "no line for trial " + std::to_string(trial) + " (expected a trial this campaign ran)");
  // The experiment as the campaign loaded it (paths given by --set resolve against its working
  // directory), then what to render: every image and a video unless render_sets say otherwise.
  std::vector<std::string> sets = meta["replay"].value("sets", std::vector<std::string>{});
  for (const char* d : {"render.keyframes=perception,close_gripper,lift,place,open_gripper_release,end",
                        "render.images=rgb,depth,segmentation", "render.video=true", "render.previews=true"})
    sets.push_back(d);
  sets.insert(sets.end(), render_sets.begin(), render_sets.end());
  sets.push_back("render.trials=" + std::to_string(trial));
  const fs::path here = fs::current_path();
  Experiment e;
  try {
    fs::current_path(meta["replay"].value("cwd", here.string()));
    e = loadExperiment(meta["replay"].value("experiment", ""), sets, {}, false);
    fs::current_path(here);
  } catch (...) {
    fs::current_path(here);
    throw;
  }
  const json fingerprint = fingerprintOf(e);
  if (meta.contains("fingerprint") && meta["fingerprint"] != fingerprint)
    throw InputError(e.file, "the experiment is not the campaign's any more (" + differences(meta["fingerprint"], fingerprint, "then", "now") +
                                 "): a replay would not be the same trial");
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
  TrialRunner runner(e, cell, tree, trial_dir.string(), meta.value("date", "2000-01-01 00:00:00"));
  // An external component is not asked again: its recorded answers are (the same requests, in order).
  runner.replayExternal(fromJsonLine(recorded.dump(), (dir / "trials.jsonl").string()).o.external_calls);
  RenderSetup setup = setUpRendering(e);
  if (!setup.renderer) throw std::runtime_error("no renderer on this machine (see the message above)");
  runner.setRenderer(setup.renderer.get(), renders.string(), setup.options);
  TrialRecord r = runOneTrial(e, robot, cell, *world, runner, trial, dir);
  RenderReplay out;
  out.dir = trialRenderDir(renders.string(), trial);
  out.files = runner.rendered();
  out.renderer = setup.renderer->description();
  listDifferences(outcomeFields(recorded), outcomeFields(json::parse(toJsonLine(r))), "", out.differences);
  out.matches = out.differences.empty();
  return out;
}

}  // namespace mm
