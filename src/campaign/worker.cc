#include "campaign/worker.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "campaign/campaign.h"
#include "campaign/results_folder.h"
#include "core/error.h"
#include "sim/hardware.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"

namespace mm {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A test's deliberate segfault or hang (the test_faults keys), before the trial runs.
void testFault(const Experiment& e, uint64_t trial, int attempt) {
  auto has = [&](const std::vector<int64_t>& v) { return std::find(v.begin(), v.end(), static_cast<int64_t>(trial)) != v.end(); };
  if (has(e.test_faults.segfault) || (attempt == 1 && has(e.test_faults.segfault_once))) {
    volatile int* null = nullptr;
    *null = 1;  // a real segmentation fault
  }
  if (has(e.test_faults.hang))
    for (;;) pause();
}

TrialRecord makeRecord(const Experiment& e, uint64_t trial, const SpawnResult& spawn, TrialOutcome o, const std::string& bt_log) {
  TrialRecord r;
  r.trial = trial;
  r.seed = e.seed;
  r.hardware = e.hardware;
  r.oracle = oracleOf(e);
  r.objects_in_bin = spawn.ok ? static_cast<int>(spawn.active.size()) : 0;  // a failed spawn put no object in play
  r.spawn_attempts = spawn.attempts;
  if (spawn.ok) r.object_grades = spawn.grades;
  r.bt_log = bt_log;
  r.o = std::move(o);
  return r;
}


}  // namespace

TrialRecord runOneTrial(const Experiment& e, const RobotModel& robot, const Cell& cell, SimWorld& world, TrialRunner& runner,
                        uint64_t trial, const fs::path& out) {
  Rng rng_scene = Rng::stream(e.seed, trial, Purpose::kScene);
  const SpawnResult spawn = spawnObjects(world, robot, cell.T_world_bin, cell.bin_half, rng_scene, cell.spawn);
  TrialOutcome o;
  std::string bt_log;
  if (!spawn.ok) {
    o.failure_stage = "spawn";
    o.failure_kind = FailureKind::kSpawn;
    o.failure_reason = spawn.reason;
  } else {
    auto hw = e.hardware == "mock" ? makeMockHardware(world, robot, spawn.active) : makeMujocoHardware(world, robot, spawn.active);
    o = runner.run(*hw, world, trial, bt_log);
  }
  return makeRecord(e, trial, spawn, std::move(o), bt_log.empty() ? "" : fs::relative(bt_log, out).string());
}

WorkerProcess spawnWorker(const std::string& binary, const std::vector<std::string>& args) {
  ChildSpec spec;
  spec.argv.push_back(binary);
  spec.argv.insert(spec.argv.end(), args.begin(), args.end());
  const ChildPipes c = startChild(spec);
  WorkerProcess w;
  w.pid = c.pid;
  w.to = c.to;
  w.from = c.from;
  return w;
}

void Watchdog::finished(double seconds) {
  if (recent_.size() < kKeep) recent_.push_back(seconds);
  else recent_[next_++ % kKeep] = seconds;
}

double Watchdog::limit() const {
  if (recent_.empty()) return floor_;
  std::vector<double> v = recent_;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return std::max(floor_, 10.0 * v[v.size() / 2]);
}

int runWorker(const Experiment& e, const std::string& out_dir) {
  // Our protocol owns the real stdout; anything else printed goes to stderr.
  // Close-on-exec: a child of ours (an external component) must not hold the supervisor's pipe open.
  const int protocol = fcntl(STDOUT_FILENO, F_DUPFD_CLOEXEC, 3);
  dup2(STDERR_FILENO, STDOUT_FILENO);
  signal(SIGPIPE, SIG_IGN);  // a write to a gone supervisor fails instead
  FILE* to_supervisor = fdopen(protocol, "w");
  if (!to_supervisor) return 1;
  const fs::path out(out_dir);
  const RobotModel robot = loadExperimentRobot(e);
  auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);
  const bt::TreeDocument tree = loadTree(e);
  const json meta = json::parse(std::ifstream(out / "campaign.json"));
  TrialRunner runner(e, cell, tree, (out / "bt").string(), meta.at("date").get<std::string>());
  const RenderSetup renders = setUpRendering(e);
  runner.setRenderer(renders.renderer.get(), (out / "renders").string(), renders.options);
  std::fprintf(to_supervisor, "READY %s\n", digest(fingerprintOf(e).dump()).c_str());
  std::fflush(to_supervisor);
  char line[128];
  while (std::fgets(line, sizeof line, stdin)) {
    unsigned long trial = 0;
    int attempt = 0;
    if (std::sscanf(line, "RUN %lu %d", &trial, &attempt) != 2) return 1;
    testFault(e, trial, attempt);
    try {
      TrialRecord r = runOneTrial(e, robot, cell, *world, runner, trial, out);
      r.attempts = attempt;
      const std::string text = toJsonLine(r);
      std::fputs(text.c_str(), to_supervisor);
      std::fputc('\n', to_supervisor);
    } catch (const OutputError& ex) {
      // Not the trial's doing: the supervisor stops the campaign and names the path and cause.
      std::string path = ex.path(), cause = ex.cause();
      for (std::string* t : {&path, &cause}) std::replace_if(t->begin(), t->end(), [](char c) { return c == '\n' || c == '\t'; }, ' ');
      std::fprintf(to_supervisor, "OUTPUT %s\t%s\n", path.c_str(), cause.c_str());
      std::fflush(to_supervisor);
      return 3;
    } catch (const std::exception& ex) {
      std::string what = ex.what();
      std::replace(what.begin(), what.end(), '\n', ' ');
      std::fprintf(to_supervisor, "ERROR %s\n", what.c_str());
      std::fflush(to_supervisor);
      return 1;
    }
    if (std::fflush(to_supervisor) != 0) return 1;
  }
  return 0;
}

}  // namespace mm
