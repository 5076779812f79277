#include "campaign/sweep.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "campaign/stats.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/folder_lock.h"

namespace mm {

namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

std::string cellName(size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "cell_%03zu", i);
  return buf;
}
}  // namespace

std::string runSweep(const Experiment& e, const CampaignOptions& o) {
  if (e.sweep.empty()) throw std::logic_error("runSweep without factors");
  for (const ParamSet::Sweep& f : e.sweep)
    for (const std::string& s : e.sets)
      if (s.rfind(f.key + "=", 0) == 0) throw InputError(f.where, "'" + f.key + "' is both swept and set by --set");
  const std::vector<std::vector<std::string>> cells = sweepCells(e.sweep);
  const FolderLock claim = FolderLock::claimBeforeStart(o.out_dir, "minimanip run (sweep)");  // the first started keeps it

  json factors = json::array(), cell_list = json::array();
  for (const ParamSet::Sweep& f : e.sweep) factors.push_back({{"key", f.key}, {"values", f.values}});
  std::vector<Experiment> experiments;
  // A path value in a file's sweep: map is relative to that file, as the file's other paths are;
  // a cell passes it on (to its workers too) as an absolute --set.
  const auto cellSetting = [&](const std::string& setting) {
    const std::string key = setting.substr(0, setting.find('=')), value = setting.substr(setting.find('=') + 1);
    for (const ParamSet::Sweep& f : e.sweep)
      if (f.key == key && !f.origin.empty() && value != "none")
        for (const ParamDecl& d : e.params.decls())
          if (d.key == key && d.kind == ParamDecl::Kind::kPath)
            return key + "=" + fs::absolute(resolvePath(value, f.origin)).lexically_normal().string();
    return setting;
  };
  for (size_t i = 0; i < cells.size(); ++i) {
    std::vector<std::string> sets = e.sets;
    for (const std::string& c : cells[i]) sets.push_back(cellSetting(c));
    // Every cell's input checked before any runs, with the file's sweep: map set aside.
    experiments.push_back(loadExperiment(e.file, sets, {}, false));  // its cross-key checks with its values
    checkCampaignInput(experiments.back());
    json settings = json::object();
    for (const std::string& s : cells[i]) settings[s.substr(0, s.find('='))] = s.substr(s.find('=') + 1);
    cell_list.push_back({{"cell", i}, {"dir", cellName(i)}, {"settings", settings}});
  }
  const json sweep = {{"experiment", e.name}, {"experiment_file", e.file}, {"seed", e.seed}, {"trials", e.trials},
                      {"factors", factors}, {"cells", cell_list}};

  const fs::path out = o.out_dir, meta = out / "sweep.json";
  if (fs::exists(meta)) {
    json old;
    try {
      old = json::parse(std::ifstream(meta));
    } catch (const std::exception& ex) {
      throw InputError(meta.string(), std::string("not JSON: ") + ex.what());
    }
    if (!old.is_object()) throw InputError(meta.string(), "not a sweep's sweep.json (expected a JSON object)");
    for (const char* k : {"experiment", "seed", "factors"})
      if (old.value(k, json()) != sweep.at(k))
        throw InputError(out.string(), std::string("holds another sweep: its ") + k + " is " + old.value(k, json()).dump() +
                                           ", this run's " + sweep.at(k).dump() + " (use another --out)");
  } else if (fs::exists(out) && !fs::is_empty(out) && !(fs::exists(out / FolderLock::kFileName) && std::distance(fs::directory_iterator(out), {}) == 1)) {
    throw InputError(out.string(), "exists and is not a sweep's results folder (use another --out)");
  }
  const FolderLock lock(out, "minimanip run (sweep)");  // one sweep per folder; each cell is locked too
  writeFileIfChanged(meta, sweep.dump(2, ' ', false, json::error_handler_t::replace) + "\n");

  size_t width = 0;
  for (const auto& c : cells) {
    size_t w = 0;
    for (const std::string& x : c) w += x.size() + 1;
    width = std::max(width, w);
  }
  std::string table = "Sweep of " + e.name + " (seed " + std::to_string(e.seed) + ", " + std::to_string(e.trials) +
                      " trials per cell, " + std::to_string(cells.size()) + " cells)\n";
  for (size_t i = 0; i < cells.size(); ++i) {
    std::string label;
    for (const std::string& s : cells[i]) label += (label.empty() ? "" : " ") + s;
    std::fprintf(stderr, "== %s: %s\n", cellName(i).c_str(), label.c_str());
    CampaignOptions co = o;
    co.out_dir = (out / cellName(i)).string();
    runCampaign(experiments[i], co);
    const json s = json::parse(std::ifstream(fs::path(co.out_dir) / "summary.json"));
    const json& y = s.at("overall_yield");
    const double rr = s.at("recovery_rate").get<double>();
    char recovery[32] = "-", cycle[32] = "-", line[512];
    if (rr >= 0) std::snprintf(recovery, sizeof recovery, "%.0f%%", 100 * rr);
    if (s.at("successes").get<long>() > 0) std::snprintf(cycle, sizeof cycle, "%.2f s", s.at("cycle_time").at("mean").get<double>());
    std::snprintf(line, sizeof line, "  %s  %-*s yield %5.1f%% [%5.1f, %5.1f]  recovery %4s  cycle %s\n", cellName(i).c_str(),
                  static_cast<int>(width), label.c_str(), 100 * y.at("value").get<double>(), 100 * y.at("ci95").at(0).get<double>(),
                  100 * y.at("ci95").at(1).get<double>(), recovery, cycle);
    table += line;
  }
  return table;
}

}  // namespace mm
