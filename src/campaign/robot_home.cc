#include "campaign/robot_home.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <sstream>

#include "campaign/trial.h"
#include "core/error.h"
#include "core/rng.h"
#include "kinematics/ik.h"
#include "planning/collision.h"
#include "sim/sim_world.h"

namespace mm {

namespace {

std::string joinValues(const VecX& q) {
  std::ostringstream o;
  o.precision(4);
  o << "[";
  for (int i = 0; i < q.size(); ++i) o << (i ? ", " : "") << q[i];
  o << "]";
  return o.str();
}

// How far q stays from its limits: the least share of a joint's range to its nearer limit.
double limitMargin(const RobotModel& robot, const VecX& q) {
  double m = 1;
  for (int j = 0; j < robot.dof(); ++j)
    m = std::min(m, std::min(q[j] - robot.lower()[j], robot.upper()[j] - q[j]) / (robot.upper()[j] - robot.lower()[j]));
  return m;
}

}  // namespace

RobotModel resolveHome(const Experiment& e, const RobotModel& robot) {
  const RobotSpec& spec = robot.spec();
  const std::string file = spec.sidecar.empty() ? spec.file : spec.sidecar;
  const auto world = loadWorld(e, robot);
  PlanningScene scene;
  scene.obstacles = world->staticObstacles();
  scene.finger_opening = spec.gripper.travel;
  if (!spec.home_source.empty()) {
    const auto checker = makeFclChecker(robot, scene, 0.0);
    if (!checker->isValid(robot.home()))
      throw InputError(file, std::string(spec.home_source == "keyframe" ? "the keyframe 'home'" : "home") + " " +
                                 joinValues(robot.home()) + " is not clear of the scene " + e.scene_path + ": " +
                                 checker->lastCollision() + " (expected a home clear of the table, the bin and the tray" +
                                 (spec.file.size() > 5 && spec.file.compare(spec.file.size() - 5, 5, ".yaml") == 0
                                      ? ")"
                                      : "; leave home out to have one found above the bin)"));
    return robot;
  }
  const auto [T_bin, bin_half] = world->site("bin_region");
  const Vec3 rim = T_bin.translation() + Vec3(0, 0, bin_half.z());
  const auto ik = makeIkSolver(e.task.ik_solver, robot);
  const auto checker = makeFclChecker(robot, scene, 0.03);
  Rng rng = Rng::stream(0, 0, Purpose::kIk, 0x4f3e);  // the cell's, not the campaign's seed: one home per cell
  std::vector<VecX> seeds = {robot.home()};
  for (int k = 0; k < 5; ++k) {
    VecX q(robot.dof());
    for (int j = 0; j < robot.dof(); ++j) q[j] = rng.uniform(robot.lower()[j], robot.upper()[j]);
    seeds.push_back(q);
  }
  const Mat3 down = Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix();
  VecX best;
  double best_margin = -1;
  int solved = 0;
  for (double h : {0.3, 0.2, 0.4})
    for (int k = 0; k < 8; ++k) {
      const Pose target = makePose(rim + Vec3(0, 0, h), Eigen::AngleAxisd(k * M_PI / 4, Vec3::UnitZ()).toRotationMatrix() * down);
      for (const VecX& seed : seeds) {
        IkRequest req = e.task.ik;
        req.target = target;
        req.seed = seed;
        req.time_cap = 10.0;  // the work-unit budget decides; the wall-clock cap is only a safety net
        const IkResult r = ik->solve(req, rng);
        if (!r.ok()) continue;
        ++solved;
        if (!checker->isValid(r.q())) continue;
        const double margin = limitMargin(robot, r.q());
        if (margin > best_margin + 1e-9) best_margin = margin, best = r.q();
      }
    }
  if (best_margin < 0)
    throw InputError(file, "no home given, and none found: of the gripper-down poses 0.2 to 0.4 m above the bin of " + e.scene_path +
                               ", " + std::to_string(solved) + " IK solutions, none clear of the scene (give home: [...] in " +
                               (spec.sidecar.empty() ? spec.file + ".yaml" : spec.sidecar) + ")");
  RobotSpec s = spec;
  s.home.assign(best.data(), best.data() + best.size());
  s.home_source = "computed";
  return RobotModel::fromSpec(s);
}

}  // namespace mm
