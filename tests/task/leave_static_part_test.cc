// A hand left with a finger inside a static part of the cell (a protective stop against a bin's
// wall) gets out: sideways out of the part, the way its nearest face is, then up.
#include <gtest/gtest.h>

#include "kinematics/ik.h"
#include "planning/collision.h"
#include "quickstart_cell.h"
#include "task/pick_place.h"

namespace mm {
namespace {

TEST(LeaveStaticPart, AFingerInsideTheBinsWallSlidesOutOfItsNearFaceThenRises) {
  const testing_task::QuickstartCell quickstart;
  const Experiment& e = quickstart.e;
  const RobotModel& robot = quickstart.robot;
  TrialContext ctx = quickstart.context(e.task);
  ctx.gripper_opening = 0.04;

  // The +x wall: the hand over the bin by it, pointing down, fingers closing along x, open.
  const Obstacle* wall = quickstart.part("bin_wall_xp");
  ASSERT_NE(wall, nullptr);
  const double inner = wall->T_world.translation().x() - wall->size.x();
  PlanningScene scene;
  scene.obstacles = quickstart.cell.statics;
  scene.finger_opening = ctx.gripper_opening;
  auto checker = makeChecker(e.task.checker, robot, scene, 0.0);
  Rng rng = Rng::stream(1, 0, Purpose::kIk);
  auto ikFrom = [&](const Pose& T_tcp, const VecX& seed, VecX& q) { return testing_task::ikNearest(ctx, e.task.ik, T_tcp, seed, rng, q); };
  Pose T = makePose(Vec3(inner - 0.1, wall->T_world.translation().y(), 0.045), Mat3(rotX(M_PI) * rotZ(M_PI / 2)));
  VecX q = robot.home();
  // Toward the wall in 1 mm steps until a finger meets it, then 4 mm into it.
  bool touched = false;
  for (int i = 0; i < 100 && !touched; ++i) {
    T.translation().x() += 0.001;
    ASSERT_TRUE(ikFrom(T, q, q));
    touched = !checker->isValid(q);
  }
  ASSERT_TRUE(touched);
  ASSERT_NE(checker->lastCollision().find("bin_wall_xp"), std::string::npos) << checker->lastCollision();
  T.translation().x() += 0.004;
  ASSERT_TRUE(ikFrom(T, q, q));
  ctx.q_rest = q;

  // Straight up alone stays inside the wall: refused.
  {
    auto up = makeChecker(e.task.checker, robot, scene, 0.0);
    Pose T_up = T;
    T_up.translation().z() += 0.1;
    EXPECT_FALSE(planCartesianLine(robot, *up, ctx.q_rest, T_up, ikFrom, e.task.cartesian).ok);
  }
  Plan plan;
  const Failure f = planRetreatUp(ctx, 0.1, plan);
  ASSERT_TRUE(f.ok()) << f.reason;
  ASSERT_EQ(plan.steps.size(), 2u);  // out, then up
  const JointTrajectory& out = plan.steps[0].trajectory;
  const Pose T_out = robot.fk(out.q.col(out.size() - 1));
  const Pose T_end = robot.fk(plan.q_end);
  // Out through the wall's near face (back over the bin), not through the wall: a few mm to cm.
  EXPECT_LT(T_out.translation().x(), T.translation().x() - 0.004);
  EXPECT_GT(T_out.translation().x(), T.translation().x() - 0.03);
  EXPECT_NEAR(T_out.translation().z(), T.translation().z(), 1e-4);
  EXPECT_NEAR(T_end.translation().z(), T.translation().z() + 0.1, 1e-4);
  // Every sample of the rise clear of everything, the wall too.
  for (int k = 0; k < plan.steps[1].trajectory.size(); ++k)
    EXPECT_TRUE(checker->isValid(plan.steps[1].trajectory.q.col(k))) << k << ": " << checker->lastCollision();
}

// A hand whose fingers are inside an object it set down (a stop as it let go): MoveToHome's start
// is in collision, and its way out (which, unlike MoveToSafe's, does not leave out the object just
// let go of by name) leaves the object out as it leaves out a perceived one the hand is inside:
// up, then home.
TEST(LeaveStaticPart, AHandInsideAnObjectItSetDownRisesOffItAndGoesHome) {
  const testing_task::QuickstartCell quickstart;
  const Experiment& e = quickstart.e;
  const RobotModel& robot = quickstart.robot;
  TrialContext ctx = quickstart.context(e.task);
  ctx.gripper_opening = 0.01;
  const Obstacle* floor = quickstart.part("bin_floor");
  ASSERT_NE(floor, nullptr);
  // A 4 cm cube set down on the bin's floor; the hand over it, pointing down, its fingers opened
  // 1 cm each, the TCP 1 cm below the cube's top: both fingers inside it.
  PickRecord placed;
  placed.object = 0;
  placed.at_target = true;
  placed.half_size = Vec3::Constant(0.02);
  const double top = floor->T_world.translation().z() + floor->size.z();
  placed.T_world_target = makePose(Vec3(floor->T_world.translation().x(), floor->T_world.translation().y(), top + 0.02), Mat3::Identity());
  ctx.out.picks.push_back(placed);
  Rng rng = Rng::stream(1, 0, Purpose::kIk);
  ASSERT_TRUE(testing_task::ikNearest(ctx, e.task.ik, makePose(placed.T_world_target.translation() + Vec3(0, 0, 0.01), Mat3(rotX(M_PI))),
                                      robot.home(), rng, ctx.q_rest));
  PlanningScene scene;
  scene.obstacles = quickstart.cell.statics;
  Obstacle box;
  box.size = placed.half_size;
  box.T_world = placed.T_world_target;
  box.name = "placed_0";
  scene.obstacles.push_back(box);
  scene.finger_opening = ctx.gripper_opening;
  auto checker = makeChecker(e.task.checker, robot, scene, 0.0);
  ASSERT_FALSE(checker->isValid(ctx.q_rest));
  ASSERT_NE(checker->lastCollision().find("placed_0"), std::string::npos) << checker->lastCollision();

  Plan plan;
  const Failure f = planHome(ctx, plan);
  ASSERT_TRUE(f.ok()) << f.reason;
  ASSERT_GE(plan.steps.size(), 2u);
  EXPECT_EQ(plan.steps.front().stage, "retreat");
  EXPECT_EQ(plan.steps.back().stage, "return_home");
  // Up off the cube: the retreat ends straight above where it started, clear of everything.
  const JointTrajectory& up = plan.steps.front().trajectory;
  const Pose T_start = robot.fk(ctx.q_rest), T_up = robot.fk(up.q.col(up.size() - 1));
  EXPECT_NEAR(T_up.translation().x(), T_start.translation().x(), 1e-4);
  EXPECT_NEAR(T_up.translation().y(), T_start.translation().y(), 1e-4);
  EXPECT_GT(T_up.translation().z(), T_start.translation().z() + 0.05);
  EXPECT_TRUE(checker->isValid(up.q.col(up.size() - 1))) << checker->lastCollision();
}

}  // namespace
}  // namespace mm
