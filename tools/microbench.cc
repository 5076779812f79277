// Google Benchmark micro-benchmarks: FK, Jacobian and every IK solver on the Panda.
//   build/minimanip_microbench [--benchmark_filter=...]
// Poses: FK of uniform random configurations (seed 7); IK seeds at joint mid-range.
#include <benchmark/benchmark.h>

#include "core/rng.h"
#include "kinematics/chain.h"
#include "kinematics/ik.h"
#include "core/camera.h"
#include "planning/collision.h"
#include "sim/sim_world.h"
#include "task/external_component.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load(MINIMANIP_SOURCE_DIR "/robots/panda/panda.yaml");
  return robot;
}

std::vector<VecX> configs(int n) {
  Rng rng(7);
  std::vector<VecX> out;
  for (int i = 0; i < n; ++i) {
    VecX q(7);
    for (int j = 0; j < 7; ++j) q[j] = rng.uniform(panda().lower()[j], panda().upper()[j]);
    out.push_back(q);
  }
  return out;
}

void BM_FastChainFk(benchmark::State& s) {
  const FastChain chain(panda());
  const auto qs = configs(256);
  Mat3 R;
  Vec3 p;
  size_t i = 0;
  for (auto _ : s) {
    chain.fk(qs[i++ & 255].data(), R, p);
    benchmark::DoNotOptimize(p);
  }
}
BENCHMARK(BM_FastChainFk);

void BM_FastChainFkJacobian(benchmark::State& s) {
  const FastChain chain(panda());
  const auto qs = configs(256);
  Mat3 R;
  Vec3 p;
  FastChain::Jac J;
  size_t i = 0;
  for (auto _ : s) {
    chain.fkJacobian(qs[i++ & 255].data(), R, p, J);
    benchmark::DoNotOptimize(J);
  }
}
BENCHMARK(BM_FastChainFkJacobian);

void BM_RobotModelLinkPoses(benchmark::State& s) {  // every link's pose (collision checking)
  const auto qs = configs(256);
  std::vector<Pose> T;
  size_t i = 0;
  for (auto _ : s) {
    panda().linkPoses(qs[i++ & 255], 0.04, T);
    benchmark::DoNotOptimize(T.data());
  }
}
BENCHMARK(BM_RobotModelLinkPoses);

void BM_RobotModelFk(benchmark::State& s) {  // the Isometry-based reference FK
  const auto qs = configs(256);
  size_t i = 0;
  for (auto _ : s) benchmark::DoNotOptimize(panda().fk(qs[i++ & 255]));
}
BENCHMARK(BM_RobotModelFk);

void BM_Ik(benchmark::State& s, const std::string& name) {
  auto solver = makeIkSolver(name, panda());
  const auto qs = configs(256);
  std::vector<Pose> targets;
  for (const auto& q : qs) targets.push_back(panda().fk(q));
  IkRequest req;
  req.seed = 0.5 * (panda().lower() + panda().upper());
  req.time_cap = 0.005;
  Rng rng(11);
  size_t i = 0, ok = 0;
  for (auto _ : s) {
    req.target = targets[i++ & 255];
    ok += solver->solve(req, rng).ok();
  }
  s.counters["success"] = benchmark::Counter(static_cast<double>(ok) / static_cast<double>(i));
}
BENCHMARK_CAPTURE(BM_Ik, analytic, std::string("analytic"));
BENCHMARK_CAPTURE(BM_Ik, hybrid, std::string("hybrid"));
BENCHMARK_CAPTURE(BM_Ik, dls, std::string("dls"));
BENCHMARK_CAPTURE(BM_Ik, kdl, std::string("kdl"));
BENCHMARK_CAPTURE(BM_Ik, kdl_restarts, std::string("kdl_restarts"));
BENCHMARK_CAPTURE(BM_Ik, trac_ik, std::string("trac_ik"))->UseRealTime();

// Collision checks of random states against the bin scene (table, bin, tray, three cubes), 1 cm
// padding; about 42% of uniform random states collide there.
void BM_Checker(benchmark::State& s, const std::string& name) {
  auto world = SimWorld::load(MINIMANIP_SOURCE_DIR "/scenes/bin_table.xml", panda());
  PlanningScene scene;
  scene.obstacles = world->staticObstacles();
  for (const Vec3& c : {Vec3(0.45, -0.2, 0.035), Vec3(0.55, -0.3, 0.035), Vec3(0.5, -0.15, 0.035)}) {
    Obstacle o;
    o.size = Vec3::Constant(0.025);
    o.T_world = makePose(c, Mat3::Identity());
    o.name = "cube";
    scene.obstacles.push_back(o);
  }
  auto checker = makeChecker(name, panda(), scene, 0.01);
  const auto qs = configs(1024);
  size_t i = 0, valid = 0;
  for (auto _ : s) valid += checker->isValid(qs[i++ & 1023]);
  s.counters["valid"] = benchmark::Counter(static_cast<double>(valid) / static_cast<double>(i));
}
BENCHMARK_CAPTURE(BM_Checker, fcl, std::string("fcl"));
BENCHMARK_CAPTURE(BM_Checker, spheres, std::string("spheres"));
BENCHMARK_CAPTURE(BM_Checker, spheres_fcl, std::string("spheres+fcl"));

// The process protocol's overhead per perception: a view's depth (float32) and colour written as
// .npy files, the request sent, and the answer read and parsed, with the reference client
// (Debian's python3) loading both images and answering no grasp (--load-only). Wall time.
void BM_ExternalRoundTrip(benchmark::State& s) {
  Frame f;
  f.camera.width = static_cast<int>(s.range(0)), f.camera.height = static_cast<int>(s.range(1));
  f.camera.fx = f.camera.fy = 554.3, f.camera.cx = (f.camera.width - 1) / 2.0, f.camera.cy = (f.camera.height - 1) / 2.0;
  const size_t pixels = static_cast<size_t>(f.camera.width) * static_cast<size_t>(f.camera.height);
  f.depth.assign(pixels, 0.9f);
  f.rgb.assign(3 * pixels, 128);
  ExternalOptions o;
  o.command = "/usr/bin/python3 tools/external_grasps.py --load-only";
  o.cwd = MINIMANIP_SOURCE_DIR;
  ExternalComponent x(o, "/dev/null");
  double write = 0, answer = 0;
  for (auto _ : s) {
    ExternalRequest r;
    r.camera = f.camera;
    const ExternalCall c = x.call(r, f);
    if (!c.ok()) {
      s.SkipWithError(c.reason.c_str());
      break;
    }
    write += c.write_seconds, answer += c.answer_seconds;
  }
  s.counters["write_ms"] = benchmark::Counter(1e3 * write / static_cast<double>(s.iterations()));
  s.counters["answer_ms"] = benchmark::Counter(1e3 * answer / static_cast<double>(s.iterations()));
}
BENCHMARK(BM_ExternalRoundTrip)->Args({640, 480})->Args({1280, 960})->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace mm

BENCHMARK_MAIN();
