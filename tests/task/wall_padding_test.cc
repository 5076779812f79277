// planning.wall_padding: a grasp cleared with a few millimetres (a grasp from the camera's points,
// grasp.cloud_padding) keeps its fingers at least wall_padding from the bin's walls.
#include <gtest/gtest.h>

#include "quickstart_cell.h"
#include "task/pick_place.h"

namespace mm {
namespace {

TEST(WallPadding, AGraspFromThePointsBesideTheBinsWallLeavesTheWallRoom) {
  const testing_task::QuickstartCell q;
  const Experiment& e = q.e;
  const RobotModel& robot = q.robot;
  const Obstacle *wall = q.part("bin_wall_xp"), *floor = q.part("bin_floor");
  ASSERT_NE(wall, nullptr);
  ASSERT_NE(floor, nullptr);
  const double inner = wall->T_world.translation().x() - wall->size.x();
  const double floor_top = floor->T_world.translation().z() + floor->size.z();

  // A 4 x 4 x 6 cm box standing in the bin, its centre `gap` from the wall's inner face, taken from
  // above by a grasp from the points closing along x: one finger goes down between it and the wall.
  const Vec3 half(0.02, 0.02, 0.03);
  auto select = [&](double centre_to_wall, double wall_padding, std::string* why, double tcp_above_centre = 0.01) {
    TaskOptions o = e.task;
    o.finger_margin = 0.006;
    o.cloud_padding = 0.002;
    o.wall_padding = wall_padding;
    TrialContext ctx = q.context(o);
    ctx.q_rest = robot.home();
    ObjectState box;
    box.index = 0;
    box.name = "object_0";
    box.half_size = half;
    box.T_world_object = makePose(Vec3(inner - centre_to_wall, wall->T_world.translation().y(), floor_top + half.z()), Mat3::Identity());
    ctx.objects = {box};
    GraspCandidate g;
    g.type = GraspType::kCloud;
    g.width = 2 * half.x();
    g.T_world_tcp = makePose(box.T_world_object.translation() + Vec3(0, 0, tcp_above_centre), Mat3(rotX(M_PI) * rotZ(M_PI / 2)));
    g.yaw = yawOf(g.T_world_tcp.linear());
    g.approach = Vec3::UnitZ();
    GraspSolution out;
    const Failure f = selectGrasp(ctx, box, {g}, 0, out);
    if (why) *why = f.reason;
    return f.ok();
  };
  // Toward the wall in 1 mm steps, with no wall padding, to the nearest the grasp passes (its
  // finger within cloud_padding and a millimetre of the wall).
  ASSERT_TRUE(select(0.06, 0.0, nullptr));
  double nearest = 0.06;
  while (nearest > half.x() && select(nearest - 0.001, 0.0, nullptr)) nearest -= 0.001;
  ASSERT_GT(nearest, half.x() + 0.006) << "the finger fits between the box and the wall";
  // There, with 6 mm of wall padding: refused, on the wall; 5 mm further from it, taken.
  std::string why;
  EXPECT_FALSE(select(nearest, 0.006, &why));
  EXPECT_NE(why.find("bin_wall_xp"), std::string::npos) << why;
  EXPECT_FALSE(select(nearest + 0.003, 0.006, nullptr));
  EXPECT_TRUE(select(nearest + 0.005, 0.006, &why)) << why;
  // Padding no larger than the grasp's own changes nothing.
  EXPECT_TRUE(select(nearest, 0.002, &why)) << why;

  // The floor's top is not grown: in the middle of the bin, the hand lowered in 1 mm steps to the
  // lowest the grasp passes with no wall padding (its fingertips within cloud_padding and a
  // millimetre of the floor) passes there with it too.
  const double middle = inner - floor->T_world.translation().x();
  double low = 0.0;
  ASSERT_TRUE(select(middle, 0.0, &why, low)) << why;
  while (low > -0.05 && select(middle, 0.0, nullptr, low - 0.001)) low -= 0.001;
  ASSERT_GT(low, -0.05) << "the fingertips meet the floor";
  EXPECT_TRUE(select(middle, 0.006, &why, low)) << why;
  EXPECT_FALSE(select(middle, 0.006, nullptr, low - 0.001));
}

}  // namespace
}  // namespace mm
