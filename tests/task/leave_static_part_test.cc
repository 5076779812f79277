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
  const Cell& cell = quickstart.cell;
  TrialContext ctx(*quickstart.hw, robot, cell.statics, e.task, cell.perception, e.seed, 0);
  ctx.gripper_opening = 0.04;

  // The +x wall: the hand over the bin by it, pointing down, fingers closing along x, open.
  const Obstacle* wall = quickstart.part("bin_wall_xp");
  ASSERT_NE(wall, nullptr);
  const double inner = wall->T_world.translation().x() - wall->size.x();
  PlanningScene scene;
  scene.obstacles = cell.statics;
  scene.finger_opening = ctx.gripper_opening;
  auto checker = makeChecker(e.task.checker, robot, scene, 0.0);
  Rng rng = Rng::stream(1, 0, Purpose::kIk);
  auto ikFrom = [&](const Pose& T_tcp, const VecX& seed, VecX& q) {
    IkRequest req = e.task.ik;
    req.target = T_tcp;
    req.seed = seed;
    req.nearest = true;
    const IkResult r = ctx.ik->solve(req, rng);
    if (r.ok()) q = r.q();
    return r.ok();
  };
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

}  // namespace
}  // namespace mm
