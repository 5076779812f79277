#include "campaign/cell_check.h"

#include <Eigen/Geometry>
#include <cmath>
#include <sstream>

#include "campaign/campaign.h"
#include "campaign/trial.h"
#include "core/rng.h"
#include "kinematics/ik.h"
#include "planning/collision.h"
#include "render/renderer.h"
#include "sim/sim_world.h"

namespace mm {

namespace {

struct Reach {
  int poses = 0, solved = 0, clear = 0;
};

// Gripper-down TCP poses on a grid over a box at height `z` in its frame, at two yaws: how many
// have an IK solution from home, and how many of those are clear of the scene's static obstacles.
Reach reachOver(const Experiment& e, const RobotModel& robot, IkSolver& ik, CollisionChecker& clear, const Pose& T_box,
                const Vec3& half, double z, int n) {
  Reach r;
  Rng rng = Rng::stream(0, 0, Purpose::kIk, 0xc4ec);
  const Mat3 down = Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < 2; ++k) {
        const double u = n == 1 ? 0 : 2.0 * i / (n - 1) - 1, v = n == 1 ? 0 : 2.0 * j / (n - 1) - 1;
        const Vec3 p = T_box * Vec3(0.8 * u * half.x(), 0.8 * v * half.y(), z);
        IkRequest req = e.task.ik;
        req.target = makePose(p, Eigen::AngleAxisd(k * M_PI / 2, Vec3::UnitZ()).toRotationMatrix() * down);
        req.seed = robot.home();
        req.time_cap = 10.0;  // the work-unit budget decides; the wall-clock cap is only a safety net
        ++r.poses;
        const IkResult s = ik.solve(req, rng);
        if (!s.ok()) continue;
        ++r.solved;
        r.clear += clear.isValid(s.q());
      }
  return r;
}

std::string share(int a, int b) {
  std::ostringstream o;
  o << a << " of " << b << " (" << static_cast<int>(std::lround(100.0 * a / std::max(b, 1))) << "%)";
  return o.str();
}

}  // namespace

CellCheck checkCell(const Experiment& e) {
  CellCheck c;
  std::ostringstream o;
  o.precision(4);
  o << checkCampaignInput(e);  // everything a run refuses, refused here; the robot as a run prints it
  const RobotModel robot = loadExperimentRobot(e);
  const RobotSpec& s = robot.spec();
  const auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);

  o << "joints:";
  for (const JointSpec& j : s.joints) o << " " << j.name << " [" << j.lower << ", " << j.upper << "]";
  o << "\n";
  o << "gripper " << s.gripper.name << " (" << s.gripper.file << ") on the flange, turned " << s.hand_yaw
    << " rad about its z, " << s.flange_d << " m out; its TCP " << s.tip_link << " " << s.tcp_offset << " m past the flange\n";
  const auto ik = makeIkSolver(e.task.ik_solver, robot);
  o << "IK solver " << ik->name() << " (kinematics.solver " << e.task.ik_solver;
  if (e.task.ik_solver == "auto")
    o << (s.analytic_ik.empty() ? ": the robot declares no closed form, so the numerical dls"
                                : ": the robot's closed form '" + s.analytic_ik + "'");
  o << ")\n";

  PlanningScene scene;
  scene.obstacles = cell.statics;
  scene.finger_opening = s.gripper.travel;
  o << "home clear of the scene, " << clearance(robot, scene, robot.home()) * 1000 << " mm from it at the nearest\n";

  const auto checker = makeFclChecker(robot, scene, 0.0);
  // Over the bin, the fingertips 1 cm above the bottom of its region (a small object's grasp); over
  // the place target, the TCP at the placed object's centre.
  const double grasp_z = -cell.bin_half.z() + robot.fingertipBelowTcp() + 0.01;
  const Reach bin = reachOver(e, robot, *ik, *checker, cell.T_world_bin, cell.bin_half, grasp_z, 5);
  const Reach place = reachOver(e, robot, *ik, *checker, cell.T_world_place_target, Vec3(0.05, 0.05, 0), 0, 3);
  for (const auto& [what, r] : {std::pair<const char*, Reach>{"the bin", bin}, {"the place target", place}}) {
    o << "reach over " << what << ": " << share(r.solved, r.poses) << " gripper-down poses have an IK solution, "
      << share(r.clear, r.poses) << " clear of the scene\n";
    if (2 * r.clear < r.poses) {
      o << "warning: the gripper reaches less than half of " << what << " pointing down: expect failed picks or places\n";
      ++c.warnings;
    }
  }

  if (e.perception.mode == PerceptionMode::kCamera) {
    std::string why;
    const auto renderer = Renderer::create(e.render.egl, &why);
    if (!renderer) {
      o << "camera: not checked (no offscreen OpenGL context: " << why << ")\n";
    } else {
      const CameraModel cam = renderer->camera(*world, e.perception.camera, e.perception.camera_width, e.perception.camera_height,
                                               e.file, "perception.camera");
      int seen = 0;
      for (int k = 0; k < 8; ++k) {
        const Vec3 corner = cell.T_world_bin * Vec3((k & 1 ? 1 : -1) * cell.bin_half.x(), (k & 2 ? 1 : -1) * cell.bin_half.y(),
                                                    (k & 4 ? 1 : -1) * cell.bin_half.z());
        const Vec3 uvz = cam.project(corner);
        seen += uvz.z() > 0 && uvz.x() >= 0 && uvz.x() <= cam.width - 1 && uvz.y() >= 0 && uvz.y() <= cam.height - 1;
      }
      o << "camera " << e.perception.camera << " sees " << seen << " of the bin's 8 corners\n";
      if (seen < 8) {
        o << "warning: the perception camera misses part of the bin\n";
        ++c.warnings;
      }
    }
  }
  c.text = o.str();
  return c;
}

}  // namespace mm
