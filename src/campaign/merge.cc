// `minimanip merge`: the results folders of one campaign's shards joined into one.
#include "campaign/campaign.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "campaign/record.h"
#include "campaign/results_folder.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/folder_lock.h"

namespace mm {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string mergeResults(const std::vector<std::string>& dirs, const std::string& out_dir, const std::string& command) {
  if (dirs.empty()) throw InputError("merge", "expected the results folders to merge");
  // Everything is checked before anything is written.
  std::vector<json> metas;
  for (const std::string& d : dirs) {
    const fs::path meta = fs::path(d) / "campaign.json";
    if (!fs::exists(meta)) throw InputError(d, "no campaign.json: not a campaign's results folder");
    try {
      metas.push_back(json::parse(std::ifstream(meta)));
    } catch (const std::exception& ex) {
      throw InputError(meta.string(), std::string("not a campaign record (") + ex.what() + ")");
    }
  }
  const long trials = metas[0].value("trials", 0L);
  for (size_t i = 1; i < dirs.size(); ++i) {
    const std::string diff = differences(metas[0].value("fingerprint", json::object()), metas[i].value("fingerprint", json::object()),
                                         "in " + dirs[0], "here");
    if (!diff.empty())
      throw InputError((fs::path(dirs[i]) / "campaign.json").string(), "another configuration than " + dirs[0] + ": " + diff);
    if (metas[i].value("trials", 0L) != trials)
      throw InputError((fs::path(dirs[i]) / "campaign.json").string(), "trials is " + std::to_string(metas[i].value("trials", 0L)) +
                                                                         ", " + std::to_string(trials) + " in " + dirs[0]);
  }
  fs::path out = fs::path(out_dir).lexically_normal();
  if (!out.has_filename()) out = out.parent_path();  // "dir/" names dir
  // A new folder, an empty one, or an earlier merge of the same campaign (a Slurm campaign
  // submitted again), which the new merge replaces whole.
  bool replaces = false;
  if (fs::exists(out) && !(fs::is_directory(out) && isEmptyFolder(out))) {
    json there;
    try {
      there = json::parse(std::ifstream(out / "campaign.json"));
    } catch (const std::exception&) {
    }
    if (!there.is_object() || !there.contains("merged_from"))
      throw InputError(out_dir, "exists and is not empty, and is not an earlier merge: merge writes a new folder");
    const std::string diff = differences(there.value("fingerprint", json::object()), metas[0].value("fingerprint", json::object()),
                                         "in " + out_dir, "in " + dirs[0]);
    if (!diff.empty()) throw InputError(out_dir, "holds the merge of another campaign (" + diff + "): merge into a new folder");
    replaces = true;
  }
  std::vector<int> owner(static_cast<size_t>(trials), -1);
  auto eachRecord = [&](const std::function<void(size_t, const std::string&, const TrialRecord&)>& f) {
    for (size_t i = 0; i < dirs.size(); ++i) {
      const fs::path path = fs::path(dirs[i]) / "trials.jsonl";
      std::ifstream in(path, std::ios::binary);
      long number = 0;
      for (std::string line; std::getline(in, line);) {
        const std::string where = path.string() + ":" + std::to_string(++number);
        if (in.eof()) throw InputError(where, "a half-written last line: resume this campaign (run it again) before merging");
        f(i, line, fromJsonLine(line, where));
      }
    }
  };
  eachRecord([&](size_t i, const std::string&, const TrialRecord& r) {
    const std::string where = (fs::path(dirs[i]) / "trials.jsonl").string();
    if (r.trial >= owner.size())
      throw InputError(where, "trial " + std::to_string(r.trial) + " is past the campaign's " + std::to_string(trials) + " trials");
    if (owner[r.trial] >= 0)
      throw InputError(where, "trial " + std::to_string(r.trial) + " is also in " + dirs[static_cast<size_t>(owner[r.trial])]);
    owner[r.trial] = static_cast<int>(i);
    if (!r.bt_log.empty() && !fs::exists(fs::path(dirs[i]) / r.bt_log))
      throw InputError(where, "trial " + std::to_string(r.trial) + "'s tree log " + r.bt_log + " is missing");
  });
  std::vector<long> missing;
  for (size_t t = 0; t < owner.size(); ++t)
    if (owner[t] < 0) missing.push_back(static_cast<long>(t));
  if (!missing.empty()) {
    std::string list;
    for (size_t k = 0; k < std::min<size_t>(missing.size(), 8); ++k) list += (k ? ", " : "") + std::to_string(missing[k]);
    throw InputError(out_dir, std::to_string(missing.size()) + " of the " + std::to_string(trials) +
                                  " trials are in none of the folders (" + list + (missing.size() > 8 ? ", ..." : "") +
                                  "): a shard missing or unfinished? Run it (again), then merge");
  }

  // Write: trials.jsonl in the folders' order, the tree logs beside it, the summary recomputed.
  // Into a folder beside it, renamed into place when complete: a failed merge removes it again,
  // and one that was killed is cleared by the next.
  const fs::path work = out.string() + ".partial";
  const FolderLock lock(work, "minimanip merge");  // one merge at a time
  CampaignSummary s;
  try {
    for (const auto& f : fs::directory_iterator(work))
      if (f.path().filename() != FolderLock::kFileName) fs::remove_all(f.path());  // a merge that was killed
    SummaryBuilder builder;
    {
      AppendFile jsonl(work / "trials.jsonl");
      eachRecord([&](size_t i, const std::string& line, const TrialRecord& r) {
        jsonl.appendLine(line);
        builder.add(r);
        if (!r.bt_log.empty()) {
          createDirectories((work / r.bt_log).parent_path());
          std::error_code ec;
          fs::copy_file(fs::path(dirs[i]) / r.bt_log, work / r.bt_log, fs::copy_options::overwrite_existing, ec);
          if (ec) throw OutputError((work / r.bt_log).string(), ec.message());
        }
      });
    }
    for (const std::string& d : dirs)  // camera renders, when a campaign has them
      if (fs::exists(fs::path(d) / "renders")) {
        std::error_code ec;
        fs::copy(fs::path(d) / "renders", work / "renders", fs::copy_options::recursive | fs::copy_options::overwrite_existing, ec);
        if (ec) throw OutputError((work / "renders").string(), ec.message());
      }
    if (fs::exists(fs::path(dirs[0]) / "config.resolved.yaml")) {
      std::ifstream in{fs::path(dirs[0]) / "config.resolved.yaml"};
      std::ostringstream text;
      text << "# " << command << "\n" << in.rdbuf();
      writeFileAtomically(work / "config.resolved.yaml", text.str());
    }
    json meta = metas[0];
    meta["command"] = command;
    meta["shard"] = "0/1";
    meta["merged_from"] = dirs;
    writeFileAtomically(work / "campaign.json", meta.dump(2, ' ', false, json::error_handler_t::replace) + "\n");

    s = builder.get();
    double wall = 0;
    for (const std::string& d : dirs) {
      const fs::path p = fs::path(d) / "summary.json";
      if (!fs::exists(p)) continue;
      std::ifstream in(p);
      std::ostringstream text;
      text << in.rdbuf();
      const CampaignSummary shard = summaryFromJson(text.str(), p.string());
      if (d == dirs[0]) {
        s.experiment = shard.experiment, s.experiment_file = shard.experiment_file, s.seed = shard.seed, s.goal = shard.goal;
        s.hardware = shard.hardware, s.tree = shard.tree, s.jobs = shard.jobs;
      }
      wall += shard.wall_seconds;
    }
    s.command = command;
    s.wall_seconds = wall;
    s.trials_per_second = wall > 0 ? s.trials / wall : 0.0;
    fillEnvironment(s);
    writeFileAtomically(work / "summary.json", toJson(s) + "\n");
  } catch (...) {
    std::error_code ec;
    fs::remove_all(work, ec);  // nothing half-made is left behind
    throw;
  }
  // Into place: an empty folder is removed, an earlier merge set aside and removed once the new
  // one stands.
  const fs::path old = out.string() + ".old";
  std::error_code ec;
  if (replaces) {
    fs::remove_all(old);
    fs::rename(out, old, ec);
  } else if (fs::exists(out)) {
    fs::remove_all(out, ec);  // empty, or holding only a lock file (checked above)
  }
  if (!ec) fs::rename(work, out, ec);
  if (ec) throw OutputError(out.string(), ec.message());
  if (replaces) fs::remove_all(old);
  return summaryTable(s);
}


}  // namespace mm
