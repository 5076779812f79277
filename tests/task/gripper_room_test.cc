// Opening the gripper where the arm rests: the fingers open as far as the cell's parts leave room.
#include <gtest/gtest.h>

#include <cmath>

#include "kinematics/ik.h"
#include "planning/collision.h"
#include "quickstart_cell.h"
#include "task/pick_place.h"

namespace mm {
namespace {

// A hand that stopped beside the bin's wall with its fingers closed (a missed grasp, then a
// protective stop on the way up): opened fully, a finger would go into the wall, which in the
// simulator is a collision (a real gripper stalls on it). It opens as far as leaves the fingers
// 3 mm from the wall, no further; over the middle of the bin, fully.
TEST(GripperRoom, ClosedFingersBesideTheBinsWallOpenOnlyAsFarAsTheWallLeavesRoom) {
  const testing_task::QuickstartCell quickstart;
  const Experiment& e = quickstart.e;
  const RobotModel& robot = quickstart.robot;
  TrialContext ctx = quickstart.context(e.task);
  ctx.gripper_opening = 0.0;
  const double travel = robot.spec().gripper.travel;
  const Obstacle* wall = quickstart.part("bin_wall_xp");
  ASSERT_NE(wall, nullptr);
  const double inner = wall->T_world.translation().x() - wall->size.x();
  PlanningScene scene;
  scene.obstacles = quickstart.cell.statics;
  auto clear = [&](double opening, double padding) {
    scene.finger_opening = opening;
    return makeChecker(e.task.checker, robot, scene, padding)->isValid(ctx.q_rest);
  };
  Rng rng = Rng::stream(1, 0, Purpose::kIk);
  auto restAt = [&](const Pose& T_tcp) {
    return testing_task::ikNearest(ctx, e.task.ik, T_tcp, ctx.q_rest.size() ? ctx.q_rest : robot.home(), rng, ctx.q_rest);
  };
  // The hand over the bin, pointing down, its fingers closing along x (towards the wall).
  Pose T = makePose(Vec3(inner - 0.1, wall->T_world.translation().y(), 0.045), Mat3(rotX(M_PI) * rotZ(M_PI / 2)));
  ASSERT_TRUE(restAt(T));
  EXPECT_NEAR(gripperPlan(ctx, travel, "open_gripper").steps.at(0).opening, travel, 1e-12) << "over the middle of the bin";
  // Towards the wall in 1 mm steps, until a finger opened fully would be in it.
  bool near = false;
  for (int i = 0; i < 100 && !near; ++i) {
    T.translation().x() += 0.001;
    ASSERT_TRUE(restAt(T));
    near = !clear(travel, 0.0);
  }
  ASSERT_TRUE(near);
  ASSERT_TRUE(clear(0.0, 0.003));
  const Plan open = gripperPlan(ctx, travel, "open_gripper");
  ASSERT_EQ(open.steps.size(), 1u);
  const double opening = open.steps[0].opening;
  EXPECT_GT(opening, 0.0);
  EXPECT_LT(opening, travel);
  EXPECT_TRUE(clear(opening, 0.003));
  EXPECT_FALSE(clear(opening + 0.0005, 0.003)) << "the widest the wall leaves, to a quarter of a millimetre";
}

}  // namespace
}  // namespace mm
