#include "campaign/bench.h"

#include <chrono>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "sim/hardware.h"
#include "sim/sim_world.h"

namespace mm {

std::string benchmarkHarness(const Experiment& e, const std::string& command_line) {
  if (e.hardware != "mujoco") throw InputError(e.file, "the harness benchmark needs hardware: mujoco");
  const RobotModel robot = RobotModel::load(e.robot_path);
  auto world = SimWorld::load(e.scene_path, robot);
  const auto [T_bin, bin_half] = world->site("bin_region");
  const auto [T_place, place_half] = world->site("place_target");
  const std::vector<Obstacle> statics = world->staticObstacles();
  Pose T_target = T_place;
  T_target.translation().z() += world->object(0).half_size.z();
  PerceptionOptions perception = e.perception;
  perception.T_world_crop = T_bin;
  perception.crop_half = bin_half;
  using Clock = std::chrono::steady_clock;
  auto secs = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };

  double wall_full = 0, wall_task = 0, sim_task = 0, wall_replay = 0, sim_replay = 0;
  long ok = 0, steps = 0;
  std::vector<double> log;
  const auto t_all = Clock::now();
  for (int64_t i = 0; i < e.trials; ++i) {
    const auto t0 = Clock::now();
    Rng rng = Rng::stream(e.seed, i, Purpose::kScene);
    const SpawnResult spawn = spawnObjects(*world, robot, T_bin, bin_half, rng, e.spawn);
    if (!spawn.ok) continue;
    const SimWorld::State start = world->saveState();
    log.clear();
    world->recordControls(&log);
    auto hw = makeMujocoHardware(*world, robot, spawn.active);
    const auto t1 = Clock::now();
    TrialContext ctx(*hw, robot, statics, e.task, perception, e.seed, i);
    runPickAndPlace(ctx, T_target);
    const TrialOutcome& o = ctx.out;
    const auto t2 = Clock::now();
    world->recordControls(nullptr);
    ok += o.success;
    wall_full += secs(t0, t2);
    wall_task += secs(t1, t2);
    sim_task += world->time() - start.time;
    // The same scene, the same controls, bare mj_step.
    world->restoreState(start);
    const auto t3 = Clock::now();
    sim_replay += world->replayControls(log);
    wall_replay += secs(t3, Clock::now());
    steps += static_cast<long>(log.size() / 9);
  }
  const double wall_total = secs(t_all, Clock::now());
  std::string cpu = "unknown";
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(2);
  o << "Harness benchmark\n";
  o << "  command:     " << command_line << "\n";
  o << "  experiment:  " << e.file << " (" << e.trials << " trials, seed " << e.seed << ", " << e.hardware << ")\n";
  o << "  machine:     " << cpu << ", " << std::thread::hardware_concurrency() << " cores, MuJoCo " << mujocoVersion()
    << ", one worker\n";
  o << "  successes:   " << ok << "/" << e.trials << "\n\n";
  o << "  full trials (spawn + settle + plan + execute): " << e.trials / wall_full << " trials/s\n";
  o << "  task only (plan + execute + monitors):         " << sim_task / wall_task << " simulated s per wall s ("
    << sim_task << " sim s in " << wall_task << " s)\n";
  o << "  pure MuJoCo, same scenes and controls:         " << sim_replay / wall_replay << " simulated s per wall s ("
    << sim_replay << " sim s, " << steps << " steps in " << wall_replay << " s)\n";
  o.precision(3);
  o << "  harness overhead (task wall / pure stepping wall for the same simulated time): "
    << (wall_task / sim_task) / (wall_replay / sim_replay) << "x\n";
  o.precision(1);
  o << "  total bench wall time: " << wall_total << " s\n";
  return o.str();
}

}  // namespace mm
