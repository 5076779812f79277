#include "planning/collision.h"

#include <gtest/gtest.h>

#include "planning/planner.h"
#include "core/error.h"

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

Obstacle box(const std::string& name, const Vec3& center, const Vec3& half) {
  Obstacle o;
  o.name = name;
  o.size = half;
  o.T_world = makePose(center, Mat3::Identity());
  return o;
}

// The table: its top at z = 0 (the robot's base stands on it).
PlanningScene tableScene() {
  PlanningScene s;
  s.obstacles.push_back(box("table", Vec3(0.4, 0, -0.375), Vec3(0.6, 0.75, 0.375)));
  return s;
}

TEST(FclChecker, HomeIsFree) {
  auto c = makeFclChecker(panda(), tableScene(), 0.01);
  EXPECT_TRUE(c->isValid(panda().home())) << c->lastCollision();
}

TEST(FclChecker, ArmFoldedIntoTheTableCollides) {
  //   z
  //   |  shoulder (0.333)
  //   |      \  upper arm pitched 100 deg forward, elbow straight:
  //   |        \___ the forearm and hand end below the table top (z = 0)
  // ==+================== table
  VecX q = panda().home();
  q[1] = 1.75;   // joint 2 near its limit: upper arm almost horizontal forward
  q[3] = -0.07;  // elbow straight
  auto c = makeFclChecker(panda(), tableScene(), 0.0);
  EXPECT_FALSE(c->isValid(q));
  EXPECT_NE(c->lastCollision().find("table"), std::string::npos) << c->lastCollision();
}

TEST(FclChecker, PaddingMakesANearMissACollision) {
  // A 2 cm cube 1.5 cm below the left fingertip (fingers open 4 cm, so the finger's middle is
  // 4.9 cm along the TCP's y; its tip 9 mm past the TCP along z): free without padding, in
  // collision with 2 cm of padding.
  const Pose T = panda().fk(panda().home());
  PlanningScene s;
  const double fingertip = 0.009;
  Obstacle cube = box("cube", T * Vec3(0, 0.049, fingertip + 0.015 + 0.01), Vec3::Constant(0.01));
  cube.T_world.linear() = T.linear();
  s.obstacles.push_back(cube);
  EXPECT_TRUE(makeFclChecker(panda(), s, 0.0)->isValid(panda().home()));
  EXPECT_FALSE(makeFclChecker(panda(), s, 0.02)->isValid(panda().home()));
}

TEST(FclChecker, SelfCollisionDetected) {
  // Elbow fully bent (joint 4 at its lower limit) with the wrist folded back (joint 6 at its lower
  // limit) brings the hand into the upper arm.
  VecX q = panda().home();
  q[3] = -3.0;
  q[5] = 0.0;
  q[4] = 0.0;
  PlanningScene empty;
  auto c = makeFclChecker(panda(), empty, 0.0);
  EXPECT_FALSE(c->isValid(q)) << "expected a self collision";
}

TEST(FclChecker, OutOfLimitsIsInvalid) {
  VecX q = panda().home();
  q[3] = 0.1;  // joint 4's upper limit is -0.0698
  auto c = makeFclChecker(panda(), tableScene(), 0.0);
  EXPECT_FALSE(c->isValid(q));
  EXPECT_EQ(c->lastCollision(), "joint limits");
}

TEST(FclChecker, HeldObjectIsChecked) {
  // Hold a 5 cm cube at the TCP and put a thin plate 3 cm below it: only the held object hits.
  const Pose T = panda().fk(panda().home());
  PlanningScene s;
  s.obstacles.push_back(box("plate", T.translation() - Vec3(0, 0, 0.055), Vec3(0.1, 0.1, 0.005)));
  EXPECT_TRUE(makeFclChecker(panda(), s, 0.0)->isValid(panda().home()));
  s.has_attached = true;
  s.attached_half = Vec3::Constant(0.025);
  s.T_tcp_attached = Pose::Identity();
  s.T_tcp_attached.translation().z() = 0.03;  // object center 3 cm further along the TCP z (down)
  auto c = makeFclChecker(panda(), s, 0.0);
  EXPECT_FALSE(c->isValid(panda().home()));
  EXPECT_NE(c->lastCollision().find("held object"), std::string::npos);
}

TEST(Planner, FindsAPathAroundAWallAndRepeatsWithTheSameSeed) {
  const RobotModel& r = panda();
  PlanningScene s = tableScene();
  // A wall between the start (arm turned to -60 deg) and the goal (+60 deg), in front of the robot.
  s.obstacles.push_back(box("wall", Vec3(0.55, 0.0, 0.25), Vec3(0.05, 0.05, 0.25)));
  auto c = makeFclChecker(r, s, 0.01);
  VecX a = r.home(), b = r.home();
  a[0] = -1.0, b[0] = 1.0;
  a[1] = b[1] = 0.3;
  ASSERT_TRUE(c->isValid(a)) << c->lastCollision();
  ASSERT_TRUE(c->isValid(b)) << c->lastCollision();
  PlannerOptions o;
  const PlanResult p1 = planJointPath(r, *c, a, b, 1234, o);
  ASSERT_TRUE(p1.ok) << p1.reason;
  for (size_t k = 1; k < p1.path.size(); ++k) EXPECT_TRUE(segmentValid(*c, p1.path[k - 1], p1.path[k], 0.01));
  const PlanResult p2 = planJointPath(r, *c, a, b, 1234, o);
  ASSERT_EQ(p1.path.size(), p2.path.size());
  for (size_t k = 0; k < p1.path.size(); ++k) EXPECT_EQ(p1.path[k], p2.path[k]);
}

TEST(Planner, GoalInCollisionFailsAtOnceWithAReason) {
  const RobotModel& r = panda();
  auto c = makeFclChecker(r, tableScene(), 0.0);
  VecX goal = r.home();
  goal[1] = 1.75, goal[3] = -0.07;
  const PlanResult p = planJointPath(r, *c, r.home(), goal, 1, {});
  EXPECT_FALSE(p.ok);
  EXPECT_NE(p.reason.find("goal state invalid"), std::string::npos) << p.reason;
}

}  // namespace
}  // namespace mm

#include <chrono>

#include "core/rng.h"
#include "sim/sim_world.h"
#include "../sanitized.h"

namespace mm {
namespace {

// The bin scene as the planner knows it: table, bin, tray (from the MJCF) and three cubes in the
// bin, 1 cm padding. Over 100,000 random states (seed 41, random finger openings), whenever FCL
// reports a collision the sphere checker does too (it is never less conservative), and the
// spheres+fcl checker agrees with FCL on every state. Under AddressSanitizer (tools/test
// --sanitize) it runs ten batches of 1,000 states instead of 10,000: that pass looks for
// memory errors, this bound is checked by the plain build.
constexpr int kStatesPerBatch = testing_sanitized::sanitizedOr(1000, 10000);
TEST(SphereChecker, NeverLessConservativeThanFclOn100kStates) {
  const RobotModel& r = panda();
  auto world = SimWorld::load("scenes/bin_table.xml", r);
  PlanningScene scene;
  scene.obstacles = world->staticObstacles();
  for (const Vec3& c : {Vec3(0.45, -0.2, 0.035), Vec3(0.55, -0.3, 0.035), Vec3(0.5, -0.15, 0.035)})
    scene.obstacles.push_back(box("cube", c, Vec3::Constant(0.025)));
  Rng rng(41);
  long fcl_hits = 0, sphere_only = 0, mismatches = 0, total = 0;
  for (int batch = 0; batch < 10; ++batch) {
    scene.finger_opening = rng.uniform(0.0, 0.04);
    auto fcl = makeFclChecker(r, scene, 0.01);
    auto spheres = makeSphereChecker(r, scene, 0.01, false);
    auto both = makeSphereChecker(r, scene, 0.01, true);
    for (int i = 0; i < kStatesPerBatch; ++i, ++total) {
      VecX q(7);
      for (int j = 0; j < 7; ++j) q[j] = rng.uniform(r.lower()[j], r.upper()[j]);
      const bool f = fcl->isValid(q), s = spheres->isValid(q), b = both->isValid(q);
      if (!f) {
        ++fcl_hits;
        ASSERT_FALSE(s) << "spheres call free a state FCL finds in collision (" << fcl->lastCollision() << "): "
                        << q.transpose();
      } else if (!s) {
        ++sphere_only;
      }
      if (b != f) ++mismatches;
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(fcl_hits, total / 100);  // the sample does exercise collisions
  EXPECT_LT(sphere_only, total / 5);  // and the spheres are not uselessly coarse
  std::printf("[ info ] %ld states: FCL collisions %ld, sphere-only collisions %ld\n", total, fcl_hits, sphere_only);
}

TEST(SphereChecker, HomeIsFreeAndTheTableCollides) {
  auto c = makeSphereChecker(panda(), tableScene(), 0.01, false);
  EXPECT_TRUE(c->isValid(panda().home())) << c->lastCollision();
  VecX q = panda().home();
  q[1] = 1.75, q[3] = -0.07;
  EXPECT_FALSE(c->isValid(q));
  EXPECT_THROW(makeChecker("bullet", panda(), tableScene(), 0.0), InputError);
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// A wall in front of the robot between two arm postures (see Planner.FindsAPathAroundAWall...):
// every planner by name finds a path whose every edge is collision-free at 1 cm resolution.
class EveryPlanner : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryPlanner, FindsACollisionFreePath) {
  seedOmplGlobally(5);
  const RobotModel& r = panda();
  PlanningScene s = tableScene();
  s.obstacles.push_back(box("wall", Vec3(0.55, 0.0, 0.25), Vec3(0.05, 0.05, 0.25)));
  auto c = makeChecker("spheres+fcl", r, s, 0.01);
  VecX a = r.home(), b = r.home();
  a[0] = -1.0, b[0] = 1.0;
  a[1] = b[1] = 0.3;
  PlannerOptions o;
  o.planner = GetParam();
  o.time_limit = 20.0;
  const PlanResult p = planJointPath(r, *c, a, b, 77, o);
  ASSERT_TRUE(p.ok) << GetParam() << ": " << p.reason;
  auto exact = makeFclChecker(r, s, 0.01);
  for (size_t k = 1; k < p.path.size(); ++k) EXPECT_TRUE(segmentValid(*exact, p.path[k - 1], p.path[k], 0.01));
  EXPECT_EQ(p.path.front(), a);
  EXPECT_EQ(p.path.back(), b);
}

INSTANTIATE_TEST_SUITE_P(Planners, EveryPlanner, ::testing::ValuesIn(plannerNames()));

// An impossible problem by construction: the checker forbids the slab |q1| < 0.1 rad of joint
// space, and start and goal lie on opposite sides of it (joint 1 cannot go around: its range is
// an interval). The planner must give up when its budget ends, with a reason, and not hang.
TEST(Planner, ImpossibleProblemFailsCleanlyWithinItsBudget) {
  struct Slab : CollisionChecker {
    bool isValid(const VecX& q) override {
      ++checks_;
      return std::abs(q[0]) >= 0.1;
    }
    std::string lastCollision() const override { return "slab"; }
  } slab;
  const RobotModel& r = panda();
  VecX a = r.home(), b = r.home();
  a[0] = -1.0, b[0] = 1.0;
  PlannerOptions o;
  o.time_limit = 0.3;
  const PlanResult p = planJointPath(r, slab, a, b, 3, o);
  EXPECT_FALSE(p.ok);
  EXPECT_NE(p.reason.find("planner RRTConnect"), std::string::npos) << p.reason;
  EXPECT_TRUE(p.hit_time_limit);
  EXPECT_GT(p.collision_checks, 100);
  EXPECT_LT(p.plan_seconds, 5.0);  // a safety net around the 0.3 s budget, not a speed test
}

}  // namespace
}  // namespace mm

#include "planning/chomp.h"

namespace mm {
namespace {

// RRT-Connect's raw path around the wall (no simplification), then CHOMP: the result keeps the
// ends, costs less, is shorter, and every edge is collision-free for exact FCL at 1 cm.
TEST(Chomp, ImprovesAPlannersPathAndStaysCollisionFree) {
  const RobotModel& r = panda();
  PlanningScene s = tableScene();
  s.obstacles.push_back(box("wall", Vec3(0.55, 0.0, 0.25), Vec3(0.05, 0.05, 0.25)));
  auto c = makeChecker("spheres+fcl", r, s, 0.01);
  VecX a = r.home(), b = r.home();
  a[0] = -1.0, b[0] = 1.0;
  a[1] = b[1] = 0.3;
  PlannerOptions o;
  o.simplify = false;
  const PlanResult p = planJointPath(r, *c, a, b, 1234, o);
  ASSERT_TRUE(p.ok) << p.reason;
  const ChompResult res = chompSmooth(r, s, *c, p.path);
  ASSERT_TRUE(res.improved) << res.reason;
  EXPECT_LT(res.cost_after, res.cost_before);
  double len = 0;
  for (size_t k = 1; k < res.path.size(); ++k) len += (res.path[k] - res.path[k - 1]).norm();
  EXPECT_LT(len, p.length);
  EXPECT_EQ(res.path.front(), a);
  EXPECT_EQ(res.path.back(), b);
  auto exact = makeFclChecker(r, s, 0.01);
  for (size_t k = 1; k < res.path.size(); ++k) EXPECT_TRUE(segmentValid(*exact, res.path[k - 1], res.path[k], 0.01)) << k;
}

// With an obstacle cost impossible to satisfy everywhere, an optimized path that fails validation
// is not returned: the input comes back unchanged, with the reason.
TEST(Chomp, NeverReturnsAnInvalidPath) {
  const RobotModel& r = panda();
  PlanningScene s = tableScene();
  struct Never : CollisionChecker {
    bool isValid(const VecX&) override { return false; }
    std::string lastCollision() const override { return "never"; }
  } never;
  const std::vector<VecX> path = {r.home(), VecX(r.home() + VecX::Constant(7, 0.2))};
  const ChompResult res = chompSmooth(r, s, never, path);
  EXPECT_FALSE(res.improved);
  EXPECT_EQ(res.path, path);
  EXPECT_FALSE(res.reason.empty());
}

}  // namespace
}  // namespace mm
