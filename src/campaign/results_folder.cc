#include "campaign/results_folder.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "core/file_io.h"
#include "core/folder_lock.h"
#include "planning/planner.h"
#include "sim/mjcf_robot.h"
#include "sim/scene_compose.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"

namespace mm {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string fixedText(double v, int precision) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(precision) << v;
  return o.str();
}

bool isEmptyFolder(const fs::path& dir) {
  for (const auto& f : fs::directory_iterator(dir))
    if (f.path().filename() != FolderLock::kFileName) return false;
  return true;
}

namespace {

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}


std::string hostName() {
  char buf[256] = "";
  gethostname(buf, sizeof buf - 1);
  return buf;
}

}  // namespace

std::string localDateTime() {
  const std::time_t now = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", std::localtime(&now));
  return buf;
}

void fillEnvironment(CampaignSummary& s) {
  s.minimanip = MINIMANIP_VERSION;
  s.mujoco = mujocoVersion();
  s.ompl = omplVersion();
  s.compiler = std::string("gcc ") + __VERSION__;
  s.cpu = cpuModel();
  s.cores = std::thread::hardware_concurrency();
  s.host = hostName();
}

std::string digest(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (const unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

std::string fileDigest(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return digest(s.str());
}

// Keys that change how a campaign runs, not what its trials do.
bool runOnlyKey(const std::string& key) {
  // Rendering reads the world and never changes it: a campaign resumed with other renders is the same campaign.
  return key == "trials" || key == "only" || key == "shard" || key == "jobs" || key == "progress" || key == "watchdog" ||
         key.rfind("render.", 0) == 0;
}

/// Every key's value as used; the robot, its gripper (the arm's default too), scene and tree by
/// their files' contents.
json fingerprintOf(const Experiment& e) {
  json f = json::object();
  for (const ParamDecl& d : e.params.decls()) {
    if (runOnlyKey(d.key)) continue;
    f[d.key] = e.params.getString(d.key);
  }
  const RobotSpec robot = loadAnyRobotSpec(e.robot_path, e.gripper_path == "default" ? "" : e.gripper_path);
  f["robot"] = "contents " + fileDigest(e.robot_path) + (robot.sidecar.empty() ? "" : " " + fileDigest(robot.sidecar));
  f["gripper"] = "contents " + fileDigest(robot.gripper.file);
  f["scene"] = "contents " + fileDigest(e.scene_path);
  for (const std::string& file : sceneSources(e.scene_path))  // its includes and URDF parts, named from its folder
    f["scene"] = f["scene"].get<std::string>() + " " + fs::path(file).lexically_relative(fs::path(e.scene_path).parent_path()).string() + ":" +
                 fileDigest(file);
  f["tree"] = "contents " + fileDigest(e.tree_path);
  {  // the catalogue and the mesh files its kinds read: a changed mesh is another campaign
    std::string digest = "contents " + fileDigest(e.spawn.catalogue);
    SpawnOptions spawn = e.spawn;
    spawn.resolve(e.file);
    for (const std::string& name : spawn.kinds)  // the kinds in play: another kind's files do not change this campaign
      for (const std::string& file : spawn.loaded.find(name)->sources) digest += " " + name + ":" + fileDigest(file);
    f["objects.catalogue"] = digest;
  }
  if (e.perception.extrinsics != "simulator") f["perception.extrinsics"] = "contents " + fileDigest(e.perception.extrinsics);
  return f;
}

/// What differs between the campaign in a results folder (`there`) and this one, in words.
std::string differences(const json& there, const json& here, const std::string& there_name, const std::string& here_name) {
  std::string said;
  int n = 0;
  std::set<std::string> keys;
  for (const auto& [k, v] : there.items()) keys.insert(k);
  for (const auto& [k, v] : here.items()) keys.insert(k);
  for (const std::string& k : keys) {
    const std::string a = there.contains(k) ? there[k].get<std::string>() : "(absent)";
    const std::string b = here.contains(k) ? here[k].get<std::string>() : "(absent)";
    if (a == b) continue;
    if (n++ == 8) {
      said += "; ...";
      break;
    }
    said += (said.empty() ? "" : "; ") +
            (a.rfind("contents ", 0) == 0 ? k + " file contents differ" : k + " is " + a + " " + there_name + ", " + b + " " + here_name);
  }
  return said;
}

ResumeState prepareResults(const Experiment& e, const fs::path& out, const json& fingerprint, const std::string& command,
                           const std::function<bool(uint64_t)>& will_run) {
  ResumeState st;
  const fs::path meta = out / "campaign.json", jsonl_path = out / "trials.jsonl";
  if (fs::exists(out / "sweep.json"))
    throw InputError(out.string(), "holds a sweep (sweep.json): a campaign of one cell goes in its own --out, or run the sweep again");
  if (fs::exists(meta)) {
    json there;
    try {
      there = json::parse(std::ifstream(meta));
    } catch (const std::exception& ex) {
      throw InputError(meta.string(), std::string("not a campaign record (") + ex.what() + "); remove the folder to start over");
    }
    const std::string diff = differences(there.value("fingerprint", json::object()), fingerprint);
    if (!diff.empty())
      throw InputError(meta.string(), "these results come from another configuration: " + diff +
                                          ". Resuming needs the same one (the trial count aside): use another --out, "
                                          "or remove the folder to start over");
    const std::string shard_there = there.value("shard", std::string("0/1"));
    if (shard_there != e.shard)
      throw InputError(meta.string(), "these results are shard " + shard_there + " of the campaign, this run is shard " + e.shard +
                                          ": use the shard's own folder");
    st.resumed = true;
    st.date = there.value("date", localDateTime());
    st.first_command = there.value("command", command);
    st.trials = std::max<long>(st.trials, there.value("trials", 0L));
  } else if (fs::exists(jsonl_path) || fs::exists(out / "summary.json")) {
    throw InputError(out.string(), "holds results but no campaign.json (not made by this version): remove it or use another --out");
  }
  createDirectories(out);
  if (e.bt_log != "none") createDirectories(out / "bt");
  if (fs::exists(out / "bt"))
    for (const auto& f : fs::directory_iterator(out / "bt"))
      if (f.path().extension() == ".tmp") fs::remove(f.path());  // a worker killed mid-write
  st.done.assign(static_cast<size_t>(e.trials), 0);
  if (st.resumed && fs::exists(jsonl_path)) {
    // Keep the complete, finished records. Read once to judge; rewrite (temp file + rename) only
    // when a line must go, so a resume with nothing to drop needs no room for a copy.
    std::vector<long> drop;  // line numbers
    {
      std::ifstream in(jsonl_path, std::ios::binary);
      std::string line;
      long number = 0;
      while (std::getline(in, line)) {
        ++number;
        if (in.eof()) {  // no newline: the supervisor died while writing it
          drop.push_back(number);
          break;
        }
        const TrialRecord r = fromJsonLine(line, jsonl_path.string() + ":" + std::to_string(number));
        if ((r.o.failure_kind == FailureKind::kCrash || r.o.failure_kind == FailureKind::kHang) && will_run(r.trial)) {
          drop.push_back(number);  // run again
          continue;
        }
        if (r.trial >= st.done.size()) st.done.resize(r.trial + 1, 0);
        if (st.done[r.trial])
          throw InputError(jsonl_path.string() + ":" + std::to_string(number), "trial " + std::to_string(r.trial) + " is recorded twice");
        st.done[r.trial] = 1;
        if (will_run(r.trial)) ++st.done_count, st.ok_count += r.o.success;  // this run's part, for the progress
      }
    }
    st.dropped_lines = static_cast<long>(drop.size());
    if (!drop.empty()) {
      const fs::path tmp = out / "trials.jsonl.tmp";
      try {
        AppendFile kept(tmp);
        std::ifstream in(jsonl_path, std::ios::binary);
        std::string line, chunk;
        long number = 0;
        size_t next_drop = 0;
        while (std::getline(in, line)) {
          ++number;
          if (next_drop < drop.size() && drop[next_drop] == number) {
            ++next_drop;
            continue;
          }
          chunk += line;
          chunk += '\n';
          if (chunk.size() > (1u << 20)) kept.append(chunk), chunk.clear();
        }
        kept.append(chunk);
        kept.close();
        if (::rename(tmp.c_str(), jsonl_path.c_str()) != 0) throw OutputError(jsonl_path.string(), errnoText(errno));
      } catch (...) {
        fs::remove(tmp);  // never left behind
        throw;
      }
    }
  } else if (!st.resumed) {
    st.date = localDateTime();
    st.first_command = command;
  }
  st.trials = std::max<long>(st.trials, static_cast<long>(e.trials));
  // How to load this experiment again (minimanip render replays a trial from it).
  const json replay = {{"experiment", fs::absolute(e.file).lexically_normal().string()},
                       {"sets", e.sets},
                       {"cwd", fs::current_path().string()}};
  st.meta = json{{"schema", 1},      {"date", st.date},           {"command", st.first_command}, {"trials", st.trials},
                 {"shard", e.shard}, {"fingerprint", fingerprint}, {"replay", replay}}
                .dump(2, ' ', false, json::error_handler_t::replace) +
            "\n";
  return st;
}

}  // namespace mm
