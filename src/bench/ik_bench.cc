#include "bench/ik_bench.h"

#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "sim/mjcf_robot.h"
#include "campaign/experiment.h"
#include "campaign/stats.h"
#include "core/error.h"
#include "core/file_io.h"
#include "grasp/grasp.h"
#include "kinematics/ik.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

VecX uniformConfig(const RobotModel& r, Rng& rng) {
  VecX q(r.dof());
  for (int j = 0; j < r.dof(); ++j) q[j] = rng.uniform(r.lower()[j], r.upper()[j]);
  return q;
}

std::vector<Pose> randomPoses(const RobotModel& r, int n, Rng& rng) {
  std::vector<Pose> out;
  for (int i = 0; i < n; ++i) out.push_back(r.fk(uniformConfig(r, rng)));
  return out;
}

// Where joint j alone brings the axes of joints j-1 and j+1 into line (the Panda's q2 = 0, q4 = 0,
// q6 = 0; the UR's wrist, q5 = 0 or pi): the relative rotation of those axes depends on q_j only.
// Roots up to 0.1 rad outside the limits count, clamped (near-singular within reach).
struct AlignmentFamily {
  int joint;
  std::vector<double> roots;
};
std::vector<AlignmentFamily> alignmentFamilies(const RobotModel& r) {
  std::vector<AlignmentFamily> out;
  std::vector<Pose> T;
  for (int j = 1; j + 1 < r.dof(); ++j) {
    auto misalignment = [&](double qj) {
      VecX q = VecX::Zero(r.dof());
      q[j] = qj;
      r.frames(q, T);
      const Vec3 a = T[j].linear() * r.jointAxis(j - 1), b = T[j + 2].linear() * r.jointAxis(j + 1);
      return a.cross(b).norm();
    };
    const double lo = r.lower()[j] - 0.1, hi = r.upper()[j] + 0.1;
    const int kGrid = 2000;
    std::vector<double> f(kGrid + 1);
    for (int k = 0; k <= kGrid; ++k) f[k] = misalignment(lo + (hi - lo) * k / kGrid);
    if (*std::max_element(f.begin(), f.end()) < 1e-9) continue;  // always parallel: not a singularity of q_j
    AlignmentFamily fam{j, {}};
    for (int k = 0; k <= kGrid; ++k) {
      if (f[k] > 0.02 || (k > 0 && f[k - 1] < f[k]) || (k < kGrid && f[k + 1] < f[k])) continue;
      // Refine the grid minimum by golden section.
      double x0 = lo + (hi - lo) * std::max(0, k - 1) / kGrid, x1 = lo + (hi - lo) * std::min(kGrid, k + 1) / kGrid;
      for (int it = 0; it < 60; ++it) {
        const double m1 = x0 + 0.382 * (x1 - x0), m2 = x0 + 0.618 * (x1 - x0);
        if (misalignment(m1) < misalignment(m2)) x1 = m2;
        else x0 = m1;
      }
      const double root = 0.5 * (x0 + x1);
      if (misalignment(root) < 1e-6) fam.roots.push_back(std::clamp(root, r.lower()[j], r.upper()[j]));
    }
    if (!fam.roots.empty()) out.push_back(fam);
  }
  return out;
}

// Smallest singular value of the TCP Jacobian (6 x dof).
double sigmaMin(const RobotModel& r, const VecX& q) {
  Jacobian J;
  r.jacobian(q, J);
  return Eigen::JacobiSVD<Eigen::MatrixXd>(J).singularValues().minCoeff();
}

// Near-singular poses, families in turn within 0.03 rad: each alignment family (a random root),
// and configurations where the Jacobian loses rank (a stretched elbow; the UR's shoulder, its
// wrist centre over the base axis), found by coordinate descent on the smallest singular value
// from a random configuration, within the limits.
std::vector<Pose> singularPoses(const RobotModel& r, int n, Rng& rng) {
  const std::vector<AlignmentFamily> align = alignmentFamilies(r);
  const int families = static_cast<int>(align.size()) + 1;
  std::vector<Pose> out;
  for (int i = 0; i < n; ++i) {
    VecX q = uniformConfig(r, rng);
    const int f = i % families;
    if (f < static_cast<int>(align.size())) {
      const AlignmentFamily& a = align[f];
      const double root = a.roots[rng.below(a.roots.size())];
      q[a.joint] = std::clamp(root + rng.uniform(-0.03, 0.03), r.lower()[a.joint], r.upper()[a.joint]);
    } else {
      for (int sweep = 0; sweep < 4; ++sweep)
        for (int j = 0; j < r.dof(); ++j) {
          double best = q[j], best_s = sigmaMin(r, q);
          for (int k = 0; k <= 64; ++k) {
            q[j] = r.lower()[j] + (r.upper()[j] - r.lower()[j]) * k / 64;
            const double sv = sigmaMin(r, q);
            if (sv < best_s) best_s = sv, best = q[j];
          }
          q[j] = best;
        }
      for (int j = 0; j < r.dof(); ++j) q[j] = std::clamp(q[j] + rng.uniform(-0.03, 0.03), r.lower()[j], r.upper()[j]);
    }
    out.push_back(r.fk(q));
  }
  return out;
}

std::vector<Pose> limitPoses(const RobotModel& r, int n, Rng& rng) {
  std::vector<Pose> out;
  for (int i = 0; i < n; ++i) {
    VecX q = uniformConfig(r, rng);
    const int k = 1 + static_cast<int>(rng.below(3));
    for (int m = 0; m < k; ++m) {
      const int j = static_cast<int>(rng.below(r.dof()));
      const double span = 0.02 * (r.upper()[j] - r.lower()[j]);
      q[j] = rng.uniform(0, 1) < 0.5 ? r.lower()[j] + rng.uniform(0, span) : r.upper()[j] - rng.uniform(0, span);
    }
    out.push_back(r.fk(q));
  }
  return out;
}

// The poses the pipeline asks for in the quickstart scene: top-down grasps (every candidate) and
// their pre-grasps for seeded bin layouts, and place poses over the tray at the symmetric yaws.
std::vector<Pose> binPoses(const RobotModel& r, const std::string& scene, int n, Rng& rng) {
  auto world = SimWorld::load(scene, r);
  const auto [T_bin, half] = world->site("bin_region");
  const auto [T_place, place_half] = world->site("place_target");
  SpawnOptions so;
  so.physics = false;
  so.count_max = 3;
  so.catalogue = resolvePath(so.catalogue, "(default)");  // the project's catalogue
  so.resolve("(default objects)");
  std::vector<Pose> out;
  const double preferred = yawOf(r.fk(r.home()).linear());
  while (static_cast<int>(out.size()) < n) {
    const SpawnResult s = spawnObjects(*world, r, T_bin, half, rng, so);
    for (int i : s.active) {
      for (const GraspCandidate& g : graspCandidates(world->object(i), preferred, Vec3::Zero(), {}, GraspOptions{})) {
        out.push_back(g.T_world_tcp);
        Pose pre = g.T_world_tcp;
        pre.translation().z() += 0.1;
        out.push_back(pre);
      }
    }
    Pose place = T_place;
    place.translation().z() += 0.03;
    place.linear() = topDownRotation(rng.uniform(-M_PI, M_PI));
    out.push_back(place);
  }
  out.resize(n);
  return out;
}

struct SolverStats {
  std::string solver;
  int threads = 1;
  long ok = 0, n = 0, capped = 0;
  std::vector<double> times_us, pos_err, rot_err;
  double distinct_mean = 0;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::ceil(p * v.size())) - 1);
  return v[k];
}

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

}  // namespace

void IkBenchOptions::declare(ConfigArchive& a) {
  a.value("robot", robot, "a robot's name under robots/ (panda, ur5e) or the path of its YAML, URDF or MJCF file");
  a.path("scene", scene, "scene MJCF of the bin set's grasp and place poses");
  a.choice("tip", tip, {"tcp", "flange"}, "the frame the poses are for (published KDL/TRAC-IK figures are for the flange)");
  a.value("poses", poses, {1, 1e7}, "", "poses per set");
  a.value("seed", seed, {0, 9.007e15}, "", "seed of the pose sets and the solvers' restarts");
  a.value("budget", budget, {1e-6, 60.0}, "s", "wall-clock cap per solve (5ms, 500us, 0.01s)");
  a.list("solvers", solvers, ikSolverNames(), "solvers to compare (empty: all)");
  a.list("sets", sets, {"random", "bin", "singular", "limits"}, "pose sets");
  a.value("distinct", distinct_poses, {0, 1e6}, "", "poses of the random set asked for up to 8 distinct solutions");
  a.path("out", out_dir, "results folder");
}

std::string runIkBench(const IkBenchOptions& o) {
  const std::string robot_path = robotPathFromName(o.robot);
  if (o.tip != "tcp" && o.tip != "flange") throw InputError("--tip " + o.tip, "expected tcp or flange");
  const RobotModel loaded = loadAnyRobot(robot_path);
  const RobotModel robot = o.tip == "flange" ? loaded.withFlangeTip() : loaded;
  std::vector<std::string> names = o.solvers;
  if (names.empty())  // every solver; "auto" is one of them under another name
    for (const auto& n : ikSolverNames())
      if (n != "auto") names.push_back(n);
  std::vector<std::unique_ptr<IkSolver>> solvers;
  for (const auto& name : names) solvers.push_back(makeIkSolver(name, robot));  // InputError on a bad name
  for (const auto& s : o.sets)
    if (s != "random" && s != "bin" && s != "singular" && s != "limits")
      throw InputError("--sets " + s, "unknown pose set (expected random, bin, singular or limits)");

  // The pose sets, each from its own stream of the seed.
  std::vector<std::pair<std::string, std::vector<Pose>>> sets;
  for (size_t k = 0; k < o.sets.size(); ++k) {
    Rng rng(mixSeed(o.seed, 1000 + k, 0));
    const std::string& s = o.sets[k];
    if (s == "random") sets.push_back({s, randomPoses(robot, o.poses, rng)});
    else if (s == "singular") sets.push_back({s, singularPoses(robot, o.poses, rng)});
    else if (s == "limits") sets.push_back({s, limitPoses(robot, o.poses, rng)});
    else sets.push_back({s, binPoses(robot, o.scene, o.poses, rng)});
  }
  const VecX mid = 0.5 * (robot.lower() + robot.upper());

  json j;
  j["command"] = o.command_line;
  j["robot"] = robot_path;
  j["tip"] = o.tip;
  j["seed"] = o.seed;
  j["poses_per_set"] = o.poses;
  j["settings"] = {{"seed_configuration", "joint mid-range"}, {"tol_position_m", 1e-5}, {"tol_rotation_rad", 1e-5},
                   {"budget_s", o.budget}, {"distinct_threshold_rad", 0.1}};
  j["machine"] = {{"cpu", cpuModel()}, {"cores", std::thread::hardware_concurrency()}};
  std::ostringstream md;
  md << std::fixed;
  md << "IK benchmark: `" << o.command_line << "`\n\n";
  md << "Robot " << robot_path << " (tip: " << o.tip << "); " << o.poses << " poses per set, seed " << o.seed
     << "; seed configuration at joint mid-range; tolerance 1e-5 m and 1e-5 rad; budget " << std::setprecision(3)
     << o.budget * 1000 << " ms per solve (wall-clock cap); " << cpuModel() << ", "
     << std::thread::hardware_concurrency() << " cores. Times are wall time per solve.\n\n";
  if (std::find(o.sets.begin(), o.sets.end(), "singular") != o.sets.end()) {
    std::string fams;
    for (const AlignmentFamily& a : alignmentFamilies(robot)) {
      fams += "joint " + std::to_string(a.joint + 1) + " at";
      for (double x : a.roots) {
        char buf[32];
        std::snprintf(buf, sizeof buf, " %.4g", x);
        fams += buf;
      }
      fams += " (axes " + std::to_string(a.joint) + " and " + std::to_string(a.joint + 2) + " aligned); ";
    }
    md << "Near-singular families, in turn: " << fams << "the Jacobian's rank lost (coordinate descent on its smallest "
       << "singular value); each within 0.03 rad.\n\n";
    j["singular_families"] = fams + "rank loss by descent";
  }
  json jsets = json::object();
  for (const auto& [set_name, poses] : sets) {
    md << "**" << set_name << "** (" << poses.size() << " poses)\n\n";
    md << "| solver | threads | success | 95% CI | mean µs | median µs | p99 µs | pos err mean / max | rot err mean / max | cap hit |"
       << (set_name == "random" ? " distinct sol. |" : "") << "\n";
    md << "|---|---|---|---|---|---|---|---|---|---|" << (set_name == "random" ? "---|" : "") << "\n";
    json jset = json::array();
    for (size_t si = 0; si < solvers.size(); ++si) {
      IkSolver& solver = *solvers[si];
      SolverStats st;
      st.solver = solver.name();
      st.threads = solver.threads();
      Rng rng(mixSeed(o.seed, 7, si));
      IkRequest req;
      req.seed = mid;
      req.time_cap = o.budget;
      for (const Pose& T : poses) {
        req.target = T;
        const auto t0 = Clock::now();
        const IkResult r = solver.solve(req, rng);
        st.times_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
        ++st.n;
        st.capped += r.hit_time_cap;
        if (r.ok()) {
          ++st.ok;
          st.pos_err.push_back(r.solutions[0].position_error);
          st.rot_err.push_back(r.solutions[0].rotation_error);
        }
      }
      if (set_name == "random" && o.distinct_poses > 0) {
        IkRequest many = req;
        many.max_solutions = 8;
        long found = 0;
        const int m = std::min<int>(o.distinct_poses, static_cast<int>(poses.size()));
        for (int i = 0; i < m; ++i) {
          many.target = poses[i];
          found += static_cast<long>(solver.solve(many, rng).solutions.size());
        }
        st.distinct_mean = static_cast<double>(found) / m;
      }
      const auto [lo, hi] = wilson95(st.ok, st.n);
      const Moments t = moments(st.times_us), pe = moments(st.pos_err), re = moments(st.rot_err);
      const double med = percentile(st.times_us, 0.5), p99 = percentile(st.times_us, 0.99);
      md << "| " << st.solver << " | " << st.threads << " | " << std::setprecision(1) << 100.0 * st.ok / st.n << "% | "
         << 100 * lo << "–" << 100 * hi << "% | " << std::setprecision(1) << t.mean << " | " << med << " | " << p99 << " | "
         << std::scientific << std::setprecision(1) << pe.mean << " / " << pe.max << " m | " << re.mean << " / " << re.max
         << " rad | " << std::fixed << st.capped << " |";
      if (set_name == "random") md << " " << std::setprecision(2) << st.distinct_mean << " |";
      md << "\n";
      jset.push_back({{"solver", st.solver}, {"threads", st.threads}, {"success", double(st.ok) / st.n},
                      {"successes", st.ok}, {"n", st.n}, {"ci95", {lo, hi}}, {"time_us", {{"mean", t.mean}, {"median", med}, {"p99", p99}, {"max", t.max}}},
                      {"position_error_m", {{"mean", pe.mean}, {"max", pe.max}}},
                      {"rotation_error_rad", {{"mean", re.mean}, {"max", re.max}}},
                      {"time_cap_hits", st.capped}, {"distinct_solutions_mean", st.distinct_mean}});
    }
    md << "\n";
    jsets[set_name] = jset;
  }
  j["sets"] = jsets;
  createDirectories(o.out_dir);
  writeFileAtomically(fs::path(o.out_dir) / "ik_bench.json", j.dump(2) + "\n");
  writeFileAtomically(fs::path(o.out_dir) / "ik_bench.md", md.str());
  return md.str();
}

}  // namespace mm
