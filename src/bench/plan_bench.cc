#include "bench/plan_bench.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "campaign/experiment.h"
#include "sim/mjcf_robot.h"
#include "campaign/stats.h"
#include "core/error.h"
#include "core/file_io.h"
#include "grasp/grasp.h"
#include "kinematics/ik.h"
#include "planning/chomp.h"
#include "planning/collision.h"
#include "planning/planner.h"
#include "planning/time_parameterization.h"
#include "planning/trajectory.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

struct Problem {
  std::string kind;  // home->pregrasp, lift->preplace, retreat->home
  int scene = 0;
  VecX start, goal;
  PlanningScene world;
};

Obstacle boxOf(const ObjectState& o) {
  Obstacle b;
  b.size = o.half_size;
  b.T_world = o.T_world_object;
  b.name = o.name;
  return b;
}

// Seeded obstacles that block the direct motions between home, bin and tray (scene frame: robot
// base at the origin, bin around (0.5, -0.25), tray around (0.45, 0.3), table top at z = 0):
// a thin divider wall between bin and tray, half the time an overhead bar, and two posts.
std::vector<Obstacle> clutter(Rng& rng) {
  std::vector<Obstacle> out;
  Obstacle wall;
  const double h = rng.uniform(0.15, 0.30);
  wall.size = Vec3(0.25, 0.005, h / 2);
  wall.T_world.translation() = Vec3(0.5, rng.uniform(0.0, 0.06), h / 2);
  wall.name = "clutter_divider";
  out.push_back(wall);
  if (rng.uniform() < 0.5) {
    Obstacle bar;
    bar.size = Vec3(0.3, 0.02, 0.02);
    bar.T_world.translation() = Vec3(0.5, rng.uniform(-0.1, 0.15), h + rng.uniform(0.25, 0.4));
    bar.name = "clutter_bar";
    out.push_back(bar);
  }
  for (int k = 0; k < 2; ++k) {
    Obstacle post;
    post.type = Obstacle::Type::kCylinder;
    const double half = rng.uniform(0.2, 0.35);
    post.size = Vec3(0.025, half, 0);
    Vec3 p;
    do {  // not inside the bin's or the tray's footprint
      p = Vec3(rng.uniform(0.15, 0.8), rng.uniform(-0.55, 0.55), half);
    } while ((std::abs(p.x() - 0.5) < 0.21 && std::abs(p.y() + 0.25) < 0.21) ||
             (std::abs(p.x() - 0.45) < 0.16 && std::abs(p.y() - 0.3) < 0.16));
    post.T_world.translation() = p;
    post.name = "clutter_post_" + std::to_string(k);
    out.push_back(post);
  }
  return out;
}

// Problems as the pick pipeline poses them, from seeded bin layouts (mock spawning: no physics).
std::vector<Problem> makeProblems(const RobotModel& robot, SimWorld& world, int scenes, uint64_t seed, double padding,
                                  bool cluttered) {
  const auto [T_bin, half] = world.site("bin_region");
  const auto [T_place, place_half] = world.site("place_target");
  const std::vector<Obstacle> scene_statics = world.staticObstacles();
  auto ik = makeIkSolver("auto", robot);
  std::vector<Problem> out;
  Rng rng(mixSeed(seed, 2024, 0));
  Rng clutter_rng(mixSeed(seed, 2024, 1));
  SpawnOptions so;
  so.physics = false;
  so.catalogue = resolvePath(so.catalogue, "(default)");  // the project's catalogue
  so.resolve("(default objects)");
  const double preferred = yawOf(robot.fk(robot.home()).linear());
  auto solve = [&](const Pose& T, const VecX& seed_q, VecX& q) {
    IkRequest req;
    req.target = T;
    req.seed = seed_q;
    req.nearest = true;
    req.limit_margin = 0.05;
    const IkResult r = ik->solve(req, rng);
    if (r.ok()) q = r.q();
    return r.ok();
  };
  for (int s = 0; s < scenes; ++s) {
    const SpawnResult spawn = spawnObjects(world, robot, T_bin, half, rng, so);
    if (!spawn.ok) continue;
    std::vector<ObjectState> objs;
    for (int i : spawn.active) objs.push_back(world.object(i));
    const ObjectState target = objs.front();
    std::vector<Obstacle> statics = scene_statics;
    // Clutter is redrawn until it leaves the home configuration free.
    bool clutter_ok = !cluttered;
    for (int draw = 0; cluttered && !clutter_ok && draw < 100; ++draw) {
      PlanningScene ps;
      ps.obstacles = scene_statics;
      for (const Obstacle& o : clutter(clutter_rng)) ps.obstacles.push_back(o);
      if (makeFclChecker(robot, ps, padding)->isValid(robot.home())) {
        statics = ps.obstacles;
        clutter_ok = true;
      }
    }
    if (!clutter_ok) continue;
    PlanningScene full;
    full.obstacles = statics;
    for (const auto& o : objs) full.obstacles.push_back(boxOf(o));
    full.finger_opening = 0.037;
    auto valid = makeFclChecker(robot, full, padding);
    std::vector<Obstacle> neighbours = statics;
    VecX q_pre, q_grasp, q_lift, q_preplace, q_retreat;
    bool found = false;
    for (const GraspCandidate& g : graspCandidates(target, preferred, Vec3::Zero(), neighbours, GraspOptions{})) {
      Pose pre = g.T_world_tcp;
      pre.translation().z() += 0.10;
      if (!solve(pre, robot.home(), q_pre) || !valid->isValid(q_pre)) continue;
      if (!solve(g.T_world_tcp, q_pre, q_grasp)) continue;
      Pose lift = g.T_world_tcp;
      lift.translation().z() += 0.15;
      if (!solve(lift, q_grasp, q_lift)) continue;
      found = true;
      // Place: the object on the tray target, then 10 cm up for the retreat.
      const Pose T_tcp_obj = g.T_world_tcp.inverse() * target.T_world_object;
      Pose T_obj = T_place;
      T_obj.translation().z() += target.half_size.z() + 0.005;
      Pose T_tcp_place = T_obj * T_tcp_obj.inverse();
      Pose preplace = T_tcp_place;
      preplace.translation().z() += 0.10;
      if (!solve(preplace, q_lift, q_preplace) || !solve(preplace, q_preplace, q_retreat)) found = false;
      if (!found) continue;
      Problem a{"home->pregrasp", s, robot.home(), q_pre, full};
      Problem b{"lift->preplace", s, q_lift, q_preplace, full};
      b.world.obstacles.clear();
      b.world.obstacles = statics;
      for (const auto& o : objs)
        if (o.index != target.index) b.world.obstacles.push_back(boxOf(o));
      b.world.has_attached = true;
      b.world.attached_half = target.half_size;
      b.world.T_tcp_attached = T_tcp_obj;
      b.world.finger_opening = target.half_size.y();
      Problem c{"retreat->home", s, q_retreat, robot.home(), b.world};
      c.world.has_attached = false;
      ObjectState placed = target;
      placed.T_world_object = T_obj;
      c.world.obstacles.push_back(boxOf(placed));
      c.world.finger_opening = 0.04;
      for (Problem* p : {&a, &b, &c}) {
        auto chk = makeFclChecker(robot, p->world, padding);
        if (chk->isValid(p->start) && chk->isValid(p->goal)) out.push_back(*p);
      }
      break;
    }
  }
  return out;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(std::ceil(p * v.size())) - 1)];
}

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

struct Run {
  bool solved = false;
  double time = 0, simplify = 0, raw_length = 0, length = 0, clearance = NAN;
  int raw_segments = 0, segments = 0;
  long checks = 0;
  std::string reason;
  std::map<std::string, double> duration;  // per time parameterization
};

struct TpStats {
  std::vector<double> duration, max_acc, rms_acc, max_jerk, rms_jerk, compute_ms;
  long within = 0, n = 0, failed = 0, interior = 0, stops = 0, backoffs = 0;
};

constexpr int kNumTps = 4;
const char* kTps[kNumTps] = {"trapezoidal", "jerk_limited_stop", "jerk_limited", "totg"};
// Methods whose jerk is bounded (the others step their acceleration).
bool jerkBounded(int tp) { return tp == 1 || tp == 2; }

}  // namespace

void PlanBenchOptions::declare(ConfigArchive& a) {
  a.value("robot", robot, "a robot's name under robots/ (panda, ur5e) or the path of its YAML, URDF or MJCF file");
  a.path("scene", scene, "scene MJCF the problems are drawn in");
  a.value("scenes", scenes, {1, 100000}, "", "seeded bin layouts (three problems each)");
  a.choice("problems", problems, {"bin", "clutter"}, "bin: the bin scene's motions; clutter: with seeded obstacles that block the direct motions");
  a.value("seed", seed, {0, 9.007e15}, "", "seed of the layouts and the planners");
  a.value("time_limit", time_limit, {1e-3, 600.0}, "s", "wall-clock cap per planning call");
  a.value("padding", padding, {0.0, 0.1}, "m", "robot inflation against the world");
  a.list("planners", planners, plannerNames(), "OMPL planners to compare (empty: all)");
  a.list("checkers", checkers, checkerNames(), "collision checkers to compare");
  a.value("simplify", simplify, "shortcut and reduce each planned path (--no-simplify: off)");
  a.choice("optimizer", optimizer, optimizerNames(), "chomp: also run each planner followed by CHOMP");
  a.path("out", out_dir, "results folder");
}

std::string runPlanBench(const PlanBenchOptions& o) {
  seedOmplGlobally(static_cast<uint32_t>(mixSeed(o.seed, 99, 0)));
  const RobotModel robot = loadAnyRobot(robotPathFromName(o.robot));
  auto world = SimWorld::load(o.scene, robot);
  std::vector<std::string> planners = o.planners.empty() ? plannerNames() : o.planners;
  for (const auto& p : planners)
    if (std::find(plannerNames().begin(), plannerNames().end(), p) == plannerNames().end())
      throw InputError("--planners " + p, "unknown planner");
  for (const auto& c : o.checkers) makeChecker(c, robot, PlanningScene{}, 0.0);  // InputError for a bad name
  const auto t_all = Clock::now();
  const std::vector<Problem> problems = makeProblems(robot, *world, o.scenes, o.seed, o.padding, o.problems == "clutter");
  if (problems.empty()) throw InputError(o.scene, "no valid planning problem could be drawn from this scene");

  struct Combo {
    std::string planner, checker;
    bool optimize = false;
    std::vector<Run> runs;
    TpStats tp[kNumTps];
  };
  std::vector<Combo> combos;
  const bool chomp = o.optimizer == "chomp";
  for (const auto& checker : o.checkers)
    for (const auto& planner : planners) {
      combos.push_back(Combo{planner, checker, false, {}, {}});
      if (chomp) combos.push_back(Combo{planner, checker, true, {}, {}});
    }
  const LimitScaling scale{0.5, 0.5};
  // Problem by problem, every combination back to back: load changes on a shared machine then
  // affect all contenders alike.
  for (size_t i = 0; i < problems.size(); ++i) {
    const Problem& p = problems[i];
    for (Combo& c : combos) {
      auto chk = makeChecker(c.checker, robot, p.world, o.padding);
      PlannerOptions po;
      po.planner = c.planner;
      po.time_limit = o.time_limit;
      po.simplify = o.simplify;
      PlanResult r = planJointPath(robot, *chk, p.start, p.goal, mixSeed(o.seed, i, 7), po);
      Run run;
      if (c.optimize && r.ok) {  // the planner's path, then CHOMP (its time counts as planning)
        const ChompResult opt = chompSmooth(robot, p.world, *chk, r.path);
        r.plan_seconds += opt.seconds;
        r.path = opt.path;
        r.length = 0;
        for (size_t k = 1; k < r.path.size(); ++k) r.length += (r.path[k] - r.path[k - 1]).norm();
      }
      run.solved = r.ok;
      run.time = r.plan_seconds;
      run.simplify = r.simplify_seconds;
      run.checks = r.collision_checks;
      run.reason = r.reason;
      if (r.ok) {
        run.raw_length = r.raw_length;
        run.raw_segments = r.raw_waypoints - 1;
        run.length = r.length;
        run.segments = static_cast<int>(r.path.size()) - 1;
        // Clearance along the path (FCL distance at 0.05 rad steps), the same reference for all.
        double cl = INFINITY;
        for (size_t k = 1; k < r.path.size(); ++k) {
          const int m = std::max(1, static_cast<int>(std::ceil((r.path[k] - r.path[k - 1]).norm() / 0.05)));
          for (int t = 0; t <= m; ++t)
            cl = std::min(cl, clearance(robot, p.world, r.path[k - 1] + (r.path[k] - r.path[k - 1]) * (double(t) / m)));
        }
        run.clearance = cl;
        for (int tp = 0; tp < kNumTps; ++tp) {
          const auto t_tp = Clock::now();
          const TimedPath timed = timeParameterize(kTps[tp], r.path, robot, scale, 0.002,
                                                   [&](const VecX& q) { return chk->isValid(q); });
          const double tp_ms = 1000 * std::chrono::duration<double>(Clock::now() - t_tp).count();
          const JointTrajectory& traj = timed.trajectory;
          TpStats& s = c.tp[tp];
          ++s.n;
          if (traj.empty()) {
            ++s.failed;
            continue;
          }
          const LimitReport lim = checkLimits(traj, robot, 1e-6);
          s.within += lim.ok && (!jerkBounded(tp) || lim.max_jerk_ratio <= 1 + 1e-6);
          s.compute_ms.push_back(tp_ms);
          s.interior += timed.interior_waypoints;
          s.stops += timed.stops;
          s.backoffs += timed.backoffs;
          s.duration.push_back(traj.duration());
          s.max_acc.push_back(lim.max_acceleration_ratio);
          s.rms_acc.push_back(lim.rms_acceleration);
          s.max_jerk.push_back(lim.max_jerk_ratio);
          s.rms_jerk.push_back(lim.rms_jerk);
          run.duration[kTps[tp]] = traj.duration();
        }
      }
      c.runs.push_back(run);
    }
  }
  const double total = std::chrono::duration<double>(Clock::now() - t_all).count();

  // ---- Markdown and JSON ----
  std::ostringstream md;
  md << std::fixed;
  md << "Planning benchmark: `" << o.command_line << "`\n\n";
  md << problems.size() << " problems from " << o.scenes << " seeded bin scenes (seed " << o.seed
     << (o.problems == "clutter" ? "; cluttered: a divider wall between bin and tray, half the time an overhead bar, two posts" : "")
     << "): home -> pre-grasp among the bin's objects, lift -> pre-place holding the object, retreat -> home. Padding "
     << std::setprecision(1) << o.padding * 1000 << " mm, time limit " << std::setprecision(1) << o.time_limit << " s per call, simplification "
     << (o.simplify ? "on" : "off") << ", optimizing planners stop at their first solution. " << cpuModel() << ", "
     << std::thread::hardware_concurrency() << " cores, one thread. Times are wall times.\n\n";
  md << "| planner | checker | success | 95% CI | plan ms mean | median | p95 | simplify ms | path length rad | min clearance mm | checks/s |\n";
  md << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  json jc = json::array();
  for (const Combo& c : combos) {
    long ok = 0;
    std::vector<double> t, simp, len, clr;
    long checks = 0;
    double plan_time = 0;
    for (const Run& r : c.runs) {
      t.push_back(1000 * r.time);
      plan_time += r.time;
      checks += r.checks;
      if (!r.solved) continue;
      ++ok;
      simp.push_back(1000 * r.simplify);
      len.push_back(r.length);
      clr.push_back(1000 * r.clearance);
    }
    const auto [lo, hi] = wilson95(ok, static_cast<long>(c.runs.size()));
    const Moments mt = moments(t), ms = moments(simp), ml = moments(len), mc = moments(clr);
    const double cps = plan_time > 0 ? checks / plan_time : 0;
    md << "| " << c.planner << (c.optimize ? "+chomp" : "") << " | " << c.checker << " | " << std::setprecision(1) << 100.0 * ok / c.runs.size() << "% | "
       << 100 * lo << "–" << 100 * hi << "% | " << std::setprecision(3) << mt.mean << " | " << percentile(t, 0.5) << " | "
       << percentile(t, 0.95) << " | " << ms.mean << " | " << std::setprecision(2) << ml.mean << " | " << std::setprecision(1)
       << mc.min << " | " << std::setprecision(0) << cps << " |\n";
    json runs = json::array();
    for (size_t i = 0; i < c.runs.size(); ++i) {
      const Run& r = c.runs[i];
      runs.push_back({{"problem", i}, {"kind", problems[i].kind}, {"solved", r.solved}, {"time_s", r.time},
                      {"simplify_s", r.simplify}, {"length", r.length}, {"raw_length", r.raw_length},
                      {"clearance_m", r.solved ? json(r.clearance) : json(nullptr)}, {"collision_checks", r.checks},
                      {"durations_s", r.duration}, {"reason", r.reason}});
    }
    json tps;
    for (int tp = 0; tp < kNumTps; ++tp) {
      const TpStats& s = c.tp[tp];
      tps[kTps[tp]] = {{"duration_mean_s", moments(s.duration).mean}, {"max_acceleration_ratio", moments(s.max_acc).max},
                       {"rms_acceleration", moments(s.rms_acc).mean}, {"max_jerk_ratio", moments(s.max_jerk).max},
                       {"rms_jerk", moments(s.rms_jerk).mean}, {"within_limits", s.within}, {"n", s.n}, {"failed", s.failed},
                       {"compute_ms_mean", moments(s.compute_ms).mean}, {"interior_waypoints", s.interior},
                       {"stops", s.stops}, {"backoffs", s.backoffs}};
    }
    jc.push_back({{"planner", c.planner + (c.optimize ? "+chomp" : "")}, {"checker", c.checker}, {"success", double(ok) / c.runs.size()}, {"ci95", {lo, hi}},
                  {"plan_ms", {{"mean", mt.mean}, {"median", percentile(t, 0.5)}, {"p95", percentile(t, 0.95)}}},
                  {"simplify_ms_mean", ms.mean}, {"path_length_mean", ml.mean}, {"min_clearance_mm", mc.min},
                  {"checks_per_second", cps}, {"time_parameterizations", tps}, {"runs", runs}});
  }
  md << "\nTime parameterizations of the same paths (velocity, acceleration and jerk scaled to 50% of the limits; "
        "jerk ratios against the Panda's jerk limits, read from the 2 ms samples; the trapezoid's and TOTG's acceleration "
        "steps make their true jerk unbounded, so only the jerk-limited methods are held to the jerk limits; TOTG blends "
        "corners within 0.05 rad; samples off the planned segments are checked with the row's checker, and the method "
        "backs off where one is invalid; stops: interior waypoints where the robot rests):\n\n";
  md << "| planner | checker | method | duration s mean | max acc / limit | RMS acc rad/s² | max jerk / limit | RMS jerk rad/s³ | "
        "within limits | stops / waypoints | back-offs | compute ms mean |\n";
  md << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Combo& c : combos)
    for (int tp = 0; tp < kNumTps; ++tp) {
      const TpStats& s = c.tp[tp];
      md << "| " << c.planner << (c.optimize ? "+chomp" : "") << " | " << c.checker << " | " << kTps[tp] << " | " << std::setprecision(3) << moments(s.duration).mean
         << " | " << moments(s.max_acc).max << " | " << std::setprecision(2) << moments(s.rms_acc).mean << " | "
         << std::setprecision(1) << moments(s.max_jerk).max << " | " << moments(s.rms_jerk).mean << " | " << s.within << "/" << s.n
         << " | " << s.stops << "/" << s.interior << " | " << s.backoffs << " | " << std::setprecision(3) << moments(s.compute_ms).mean << " |\n";
    }
  createDirectories(o.out_dir);
  json j;
  j["command"] = o.command_line;
  j["seed"] = o.seed;
  j["problems"] = problems.size();
  j["problem_set"] = o.problems;
  j["settings"] = {{"padding_m", o.padding}, {"time_limit_s", o.time_limit}, {"simplify", o.simplify}, {"scaling", 0.5}};
  j["machine"] = {{"cpu", cpuModel()}, {"cores", std::thread::hardware_concurrency()}};
  j["combinations"] = jc;
  writeFileAtomically(fs::path(o.out_dir) / "plan_bench.json", j.dump(2) + "\n");
  writeFileAtomically(fs::path(o.out_dir) / "plan_bench.md", md.str());

  // ---- OMPL benchmark log (OMPL's "benchmark logfile format"; checked by loading it with OMPL's own
  // ompl_benchmark_statistics into the database Planner Arena reads, in tests/campaign/plan_bench_test.cc) ----
  std::ostringstream log;
  char host[256] = "";
  gethostname(host, sizeof host - 1);
  const std::time_t now = std::time(nullptr);
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S", std::gmtime(&now));
  log << "OMPL version " << omplVersion() << "\n";
  log << "Experiment minimanip_bin_scene\n";
  log << "2 experiment properties\n";
  log << "problems INTEGER = " << problems.size() << "\n";  // "name TYPE = value", as OMPL writes and parses
  log << "padding REAL = " << o.padding << "\n";
  log << "Running on " << host << "\n";
  log << "Starting at " << date << "\n";
  log << "<<<|\n" << o.command_line << "\n|>>>\n";
  log << "<<<|\n" << cpuModel() << "\n|>>>\n";
  log << static_cast<uint32_t>(mixSeed(o.seed, 99, 0)) << " is the random seed\n";
  log << o.time_limit << " seconds per run\n";
  log << "4096 MB per run\n";
  log << problems.size() << " runs per planner\n";
  log << total << " seconds spent to collect the data\n";
  log << "0 enum type\n";
  log << combos.size() << " planners\n";
  for (const Combo& c : combos) {
    log << "geometric_" << c.planner << (c.optimize ? "_chomp" : "") << "_" << c.checker << "\n";
    log << "2 common properties\n";
    log << "collision checker = " << c.checker << "\n";
    log << "simplify = " << (o.simplify ? 1 : 0) << "\n";
    log << 9 + kNumTps << " properties for each run\n";
    log << "time REAL\nsolved BOOLEAN\nsimplification time REAL\nsolution length REAL\nsimplified solution length REAL\n"
           "solution segments INTEGER\nsimplified solution segments INTEGER\ncollision checks INTEGER\n"
           "simplified solution clearance REAL\n";
    for (int tp = 0; tp < kNumTps; ++tp) log << "trajectory duration " << kTps[tp] << " REAL\n";
    log << c.runs.size() << " runs\n";
    for (const Run& r : c.runs) {
      auto num = [&](double v) { return r.solved ? std::to_string(v) : std::string(""); };
      log << r.time << "; " << (r.solved ? 1 : 0) << "; " << num(r.simplify) << "; " << num(r.raw_length) << "; "
          << num(r.length) << "; " << (r.solved ? std::to_string(r.raw_segments) : "") << "; "
          << (r.solved ? std::to_string(r.segments) : "") << "; " << r.checks << "; " << num(r.clearance) << "; ";
      for (int tp = 0; tp < kNumTps; ++tp)
        log << (r.solved && r.duration.count(kTps[tp]) ? std::to_string(r.duration.at(kTps[tp])) : "") << "; ";
      log << "\n";
    }
    log << ".\n";
  }
  writeFileAtomically(fs::path(o.out_dir) / "plan_bench.log", log.str());
  return md.str();
}

}  // namespace mm
