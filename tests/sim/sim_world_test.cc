// The simulator's monitors, the two hardware backends, and the mid-phase and sleeping.
#include "sim/sim_world.h"

#include <mujoco/mujoco.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <fcl/fcl.h>
#include <unistd.h>

#include <cmath>

#include "planning/trajectory.h"
#include "sim/controllers.h"
#include "sim/hardware.h"
#include "core/error.h"
#include "sim/scene_compose.h"
#include "sim/midphase.h"
#include "core/rng.h"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace mm {
namespace {

const RobotModel& panda() {
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  return robot;
}

// n of the catalogue's 5 cm cubes, coloured as objects 0..n-1.
std::vector<ObjectKind> cubes(int n) {
  static const ObjectCatalogue c = loadObjectCatalogue("scenes/objects.yaml");
  std::vector<ObjectKind> out;
  for (int k = 0; k < n; ++k) out.push_back(c.asObject(*c.find("cube_5cm"), k));
  return out;
}

std::unique_ptr<SimWorld> world() { return SimWorld::load("scenes/bin_table.xml", panda(), cubes(3)); }

TEST(SimWorld, NanStateEndsAsUnstableWithAReason) {
  auto w = world();
  VecX q = panda().home();
  q[2] = std::nan("");
  w->setArm(q);
  const VecX zero = VecX::Zero(7);
  w->stepServo(panda().home(), zero, zero, 0.04, 40);
  EXPECT_TRUE(w->unstable());
  EXPECT_THAT(w->instabilityReason(), ::testing::HasSubstr("bad qpos"));
  // Through the controller the trial sees a SIM_UNSTABLE failure, not a crash.
  auto hw = makeMujocoHardware(*w, panda(), {});
  JointTrajectory t;
  t.q = t.qd = t.qdd = Eigen::MatrixXd::Zero(7, 3);
  for (int k = 0; k < 3; ++k) t.q.col(k) = panda().home();
  const ExecutionResult r = executeTrajectory(*hw, t, 0.04, 40, {}, panda());
  EXPECT_FALSE(r.ok);
  EXPECT_THAT(r.reason, ::testing::StartsWith("SIM_UNSTABLE"));
}

// Where MuJoCo flags a bad state it resets its data (objects parked, time 0): the world goes back
// to the start of that control period instead and stays there, time going on, so a trial scores
// what it did before (pile round 51 of seed 3 kept its 5 placed objects).
TEST(SimWorld, AnUnstableStepLeavesTheWorldWhereItWasGood) {
  auto w = world();
  const VecX zero = VecX::Zero(7);
  for (int k = 0; k < 10; ++k) w->stepServo(panda().home(), zero, zero, 0.04, 40);
  ASSERT_FALSE(w->unstable());
  const double t0 = w->time();
  std::vector<Vec3> before;
  for (int i = 0; i < 3; ++i) before.push_back(w->object(i).T_world_object.translation());
  VecX q = panda().home();
  q[2] = std::nan("");
  w->setArm(q);
  w->stepServo(panda().home(), zero, zero, 0.04, 40);
  ASSERT_TRUE(w->unstable());
  EXPECT_DOUBLE_EQ(w->time(), t0);
  for (int i = 0; i < 3; ++i) EXPECT_LT((w->object(i).T_world_object.translation() - before[static_cast<size_t>(i)]).norm(), 1e-12) << i;
  w->stepServo(panda().home(), zero, zero, 0.04, 40);
  EXPECT_GT(w->time(), t0);
  for (int i = 0; i < 3; ++i) EXPECT_LT((w->object(i).T_world_object.translation() - before[static_cast<size_t>(i)]).norm(), 1e-12) << i;
}

TEST(SimWorld, DrivingTheHandIntoTheTableCountsOneCollisionEvent) {
  // Home has the TCP 0.49 m above the table; joint 2 pitched forward to 1.3 rad pushes the hand
  // through the table top (z = 0) between the bin and the tray.
  auto w = world();
  auto hw = makeMujocoHardware(*w, panda(), {});
  VecX q = panda().home();
  const VecX zero = VecX::Zero(7);
  for (int k = 0; k < 1000; ++k) {
    q[1] = std::min(1.3, -0.785398 + k * 0.004);
    hw->write(q, zero, zero);
    hw->step();
  }
  EXPECT_EQ(w->collisionEvents(), 1) << ::testing::PrintToString(w->collisionLog());
  ASSERT_FALSE(w->collisionLog().empty());
  EXPECT_THAT(w->collisionLog()[0], ::testing::HasSubstr("hit table"));
  EXPECT_FALSE(w->unstable());
}

TEST(SimWorld, AMotionIntoTheTableStopsOnContactForceWhereTheJointsAre) {
  // The same dive into the table as above, as a trajectory under the protective stop on contact
  // force (20 N): the motion fails as kContactForce and the arm stays about where it touched, far
  // short of the trajectory's end; the force seen in free flight is ~0.
  auto w = world();
  auto hw = makeMujocoHardware(*w, panda(), {});
  const int n = 1000;
  JointTrajectory t = JointTrajectory::startingAt(panda().home(), n, 0.002);
  for (int k = 0; k < n; ++k) {
    t.q.col(k) = panda().home();
    // Smooth from -0.785 to 1.3 rad over 2 s (cosine profile).
    const double s = 0.5 - 0.5 * std::cos(M_PI * k / (n - 1.0));
    t.q(1, k) = -0.785398 + s * (1.3 + 0.785398);
  }
  differentiate(t);
  double free_flight = 0;
  const StepMonitor watch = [&] {
    if (w->collisionEvents() == 0) free_flight = std::max(free_flight, hw->externalForce());
    return Failure{};
  };
  TrajectoryMotion m(t, 0.04, 40, watch, panda(), 0.3, 0.0, 20.0);
  runToEnd(*hw, m);
  EXPECT_EQ(m.state(), MotionState::kFailed);
  EXPECT_EQ(m.failure().kind, FailureKind::kContactForce) << m.failure().reason;
  EXPECT_THAT(m.failure().reason, ::testing::HasSubstr("protective stop"));
  EXPECT_LT(free_flight, 1.0);
  // Stopped near where the hand met the table (about 0.7 rad; the table top at joint 2 ~ 0.75).
  EXPECT_LT(hw->jointPositions()[1], 1.0);
  // Without the limit the same motion drives on into the table (the tracking error alone is off
  // here): it ends pressing far harder than the stopped arm holds.
  auto w2 = world();
  auto hw2 = makeMujocoHardware(*w2, panda(), {});
  TrajectoryMotion free(t, 0.04, 40, {}, panda(), 0.3, 0.0, 0.0);
  runToEnd(*hw2, free);
  const double stopped = hw->externalForce(), driven = hw2->externalForce();
  EXPECT_GT(driven, 2 * stopped) << "stopped: " << stopped << " N, driven on: " << driven << " N";
}

JointTrajectory dive(double to = 1.3) {
  // Joint 2 pitched forward from home over 2 s (cosine profile): the hand sweeps down and forward.
  const int n = 1000;
  JointTrajectory t = JointTrajectory::startingAt(panda().home(), n, 0.002);
  for (int k = 0; k < n; ++k) {
    t.q.col(k) = panda().home();
    const double s = 0.5 - 0.5 * std::cos(M_PI * k / (n - 1.0));
    t.q(1, k) = -0.785398 + s * (to + 0.785398);
  }
  differentiate(t);
  return t;
}

TEST(SimWorld, AProtectiveStopBrakesTheArmWhereItStopped) {
  // A stop on contact force holds the arm at the servo's high joint impedance, as a robot's brakes
  // or its reflex's stiff hold do: the hand that dove onto the table stays where it stopped.
  auto w = world();
  auto hw = makeMujocoHardware(*w, panda(), {});
  VecX at_stop;  // the monitor is not called once the motion has stopped: its last call is the period before
  const StepMonitor watch = [&] {
    at_stop = hw->jointPositions();
    return Failure{};
  };
  TrajectoryMotion m(dive(), 0.04, 40, watch, panda(), 0.3, 0.0, 20.0);
  runToEnd(*hw, m);
  ASSERT_EQ(m.failure().kind, FailureKind::kContactForce) << m.failure().reason;
  ASSERT_EQ(at_stop.size(), hw->jointPositions().size());
  // Held where it stopped (no further than the period it took to brake) and holding its ground:
  // at the servo's own gains the arm yielded off the table (7 N at the end, 62 N braked).
  EXPECT_LT((hw->jointPositions() - at_stop).cwiseAbs().maxCoeff(), 0.02);
  EXPECT_GT(hw->externalForce(), 30.0);
}

TEST(SimWorld, AGuardedDescentEndsAtTouchDownOnlyWhenTheHandTouches) {
  // A guarded move (a place descent): the fingers meeting a surface is touch-down, a success, with
  // the arm held where it touched; another link hitting something is still a protective stop.
  {
    auto w = world();
    // A column whose top the fingertips meet 10 cm into the dive (joint 2 at -0.5 rad).
    VecX q = panda().home();
    q[1] = -0.5;
    const Vec3 tcp = panda().fk(q).translation();
    const Vec3 half = w->obstacleHalfSize(0);
    w->placeObstacle(0, makePose(Vec3(tcp.x(), tcp.y(), tcp.z() - 0.02 - half.z()), Mat3::Identity()));
    auto hw = makeMujocoHardware(*w, panda(), {});
    TrajectoryMotion m(dive(), 0.0, 40, {}, panda(), 0.3, 0.0, 20.0, /*guarded=*/true);
    runToEnd(*hw, m);
    EXPECT_EQ(m.state(), MotionState::kSucceeded) << m.failure().reason << ::testing::PrintToString(w->collisionLog());
    EXPECT_TRUE(m.touchedDown());
    EXPECT_LT(m.duration(), 2.0);  // the trajectory alone takes 2 s
    EXPECT_LT(hw->jointPositions()[1], -0.3);
    EXPECT_LT((hw->commandedPositions() - hw->jointPositions()).cwiseAbs().maxCoeff(), 0.02);
  }
  {
    // The plain dive: link 7 meets the table before the hand does.
    auto w = world();
    auto hw = makeMujocoHardware(*w, panda(), {});
    TrajectoryMotion m(dive(), 0.04, 40, {}, panda(), 0.3, 0.0, 20.0, /*guarded=*/true);
    runToEnd(*hw, m);
    EXPECT_EQ(m.state(), MotionState::kFailed);
    EXPECT_EQ(m.failure().kind, FailureKind::kContactForce) << m.failure().reason;
    EXPECT_FALSE(m.touchedDown());
  }
}

TEST(MockHardware, HeldObjectMovesWithTheHandAndRestsWhenReleased) {
  auto w = world();
  const Pose T_tcp = panda().fk(panda().home());
  // A cube floating between the open fingers at the TCP (mock: nothing falls unless released).
  w->setObjectPose(0, makePose(T_tcp.translation(), Mat3::Identity()));
  auto hw = makeMockHardware(*w, panda(), {0});
  const GripperResult closed = moveGripper(*hw, panda().home(), 0.0, 40);
  EXPECT_NEAR(closed.opening, 0.025, 1e-6);  // stopped on the 5 cm cube
  // Turn joint 1 by 0.3 rad: the cube follows the TCP exactly.
  VecX q = panda().home();
  q[0] = 0.3;
  const VecX zero = VecX::Zero(7);
  hw->write(q, zero, zero);
  hw->step();
  EXPECT_LT((hw->object(0).T_world_object.translation() - panda().fk(q).translation()).norm(), 1e-9);
  EXPECT_EQ(hw->jointPositions(), q);
  // Open: the cube drops onto the table top (z = 0) below.
  moveGripper(*hw, q, 0.04, 40);
  EXPECT_NEAR(hw->object(0).T_world_object.translation().z(), 0.025, 1e-6);
}

TEST(SimWorld, ExportsTheStaticSceneForThePlanner) {
  auto w = world();
  const auto obstacles = w->staticObstacles();
  std::vector<std::string> names;
  for (const auto& o : obstacles) names.push_back(o.name);
  EXPECT_THAT(names, ::testing::IsSupersetOf({"table", "bin_floor", "bin_wall_xp", "tray_floor", "tray_wall_yn"}));
  EXPECT_THAT(names, ::testing::Not(::testing::Contains("floor")));  // the ground plane is out of reach
}

// ---- what makes the physics fast must not change it --------------------------------------------
// The mid-phase finds exactly MuJoCo's contacts; a sleeping object wakes before anything moving
// reaches it, and only objects resting on the world sleep.

struct Contact {
  int g1, g2;
  double dist;
};

std::vector<Contact> contacts(SimWorld& w, bool midphase) {
  const mjModel* m = w.mujocoModel();
  mjData* d = w.mujocoData();
  setMidphase(midphase);
  mj_fwdPosition(m, d);
  std::vector<Contact> out;
  for (int i = 0; i < d->ncon; ++i) out.push_back({d->contact[i].geom1, d->contact[i].geom2, d->contact[i].dist});
  return out;
}

TEST(Midphase, FindsExactlyMuJoCosContacts) {
  installMujocoHandlers();
  auto w = SimWorld::load("scenes/bin_table.xml", panda(), cubes(3));
  Rng rng(7);
  int with_contacts = 0, total = 0;
  for (int n = 0; n < 400; ++n) {
    VecX q(7);
    for (int j = 0; j < 7; ++j) q[j] = rng.uniform(panda().lower()[j], panda().upper()[j]);
    w->setArm(q);
    w->setFingers(rng.uniform(0.0, 0.04));
    // Cubes near the hand, on the bin floor, against its walls, on one another, turned anyhow.
    const Vec3 tcp = panda().fk(q).translation();
    for (int i = 0; i < 3; ++i) {
      Vec3 p;
      switch (n % 4) {
        case 0: p = tcp + Vec3(rng.uniform(-0.06, 0.06), rng.uniform(-0.06, 0.06), rng.uniform(-0.06, 0.06)); break;
        case 1: p = Vec3(rng.uniform(0.33, 0.67), rng.uniform(-0.42, -0.08), rng.uniform(0.02, 0.05)); break;
        case 2: p = Vec3(rng.uniform(0.43, 0.47), rng.uniform(-0.27, -0.23), 0.035 + 0.049 * i); break;
        default: p = Vec3(rng.uniform(-0.2, 1.0), rng.uniform(-0.7, 0.7), rng.uniform(-0.03, 0.5)); break;
      }
      const Quat r(Eigen::AngleAxisd(rng.uniform(0, 2 * M_PI), Vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), 1).normalized()));
      w->setObjectPose(i, makePose(p, r));
    }
    const auto plain = contacts(*w, false), fast = contacts(*w, true);
    ASSERT_EQ(plain.size(), fast.size()) << "sample " << n;
    for (size_t k = 0; k < plain.size(); ++k) {
      EXPECT_EQ(plain[k].g1, fast[k].g1);
      EXPECT_EQ(plain[k].g2, fast[k].g2);
      EXPECT_NEAR(plain[k].dist, fast[k].dist, 1e-12) << plain[k].dist - fast[k].dist;
    }
    with_contacts += !plain.empty();
    total += static_cast<int>(plain.size());
  }
  EXPECT_GT(with_contacts, 150) << "the samples meet things";
  EXPECT_GT(total, 1000);
}

// Sleeping wakes an object when something comes within 2 cm of it by a lower bound on the gap
// between the shapes: it must never exceed their true distance (FCL's), or an object could sleep
// on while something reaches it.
TEST(Midphase, GapBoundNeverExceedsTheDistance) {
  installMujocoHandlers();
  const std::filesystem::path xml = std::filesystem::temp_directory_path() / ("mm_gap_" + std::to_string(getpid()) + ".xml");
  std::ofstream(xml) << R"(<mujoco><worldbody>
    <body><freejoint/><geom type="box" size="0.025 0.04 0.015"/></body>
    <body><freejoint/><geom type="box" size="0.0105 0.009 0.027"/></body>
    <body><freejoint/><geom type="capsule" size="0.03 0.06"/></body>
    <body><freejoint/><geom type="sphere" size="0.02"/></body>
  </worldbody></mujoco>)";
  char error[500] = "";
  mjModel* m = mj_loadXML(xml.c_str(), nullptr, error, sizeof error);
  std::filesystem::remove(xml);
  ASSERT_NE(m, nullptr) << error;
  mjData* d = mj_makeData(m);
  auto shape = [&](int g) -> std::shared_ptr<fcl::CollisionGeometryd> {
    const mjtNum* s = m->geom_size + 3 * g;
    if (m->geom_type[g] == mjGEOM_BOX) return std::make_shared<fcl::Boxd>(2 * s[0], 2 * s[1], 2 * s[2]);
    if (m->geom_type[g] == mjGEOM_CAPSULE) return std::make_shared<fcl::Capsuled>(s[0], 2 * s[1]);
    return std::make_shared<fcl::Sphered>(s[0]);
  };
  auto pose = [&](int g) {
    fcl::Transform3d T = fcl::Transform3d::Identity();
    for (int r = 0; r < 3; ++r) {
      T.translation()[r] = d->geom_xpos[3 * g + r];
      for (int c = 0; c < 3; ++c) T.linear()(r, c) = d->geom_xmat[9 * g + 3 * r + c];
    }
    return T;
  };
  Rng rng(11);
  int pairs = 0, tight = 0;
  for (int n = 0; n < 3000; ++n) {
    for (int b = 0; b < 4; ++b) {  // every body within 15 cm of the origin, turned anyhow
      mjtNum* q = d->qpos + 7 * b;
      for (int k = 0; k < 3; ++k) q[k] = rng.uniform(-0.075, 0.075);
      const Quat r(Eigen::AngleAxisd(rng.uniform(0, 2 * M_PI), Vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)).normalized()));
      q[3] = r.w(), q[4] = r.x(), q[5] = r.y(), q[6] = r.z();
    }
    mj_kinematics(m, d);
    for (int g1 = 0; g1 < 2; ++g1)  // a box against each other shape
      for (int g2 = g1 + 1; g2 < 4; ++g2) {
        fcl::DistanceRequestd req;
        fcl::DistanceResultd res;
        fcl::distance(shape(g1).get(), pose(g1), shape(g2).get(), pose(g2), req, res);
        const double bound = geomGapLowerBound(m, d, g1, g2);
        const double dist = std::max(0.0, res.min_distance);  // FCL: <= 0 when they overlap
        ASSERT_LE(bound, dist + 1e-9) << "sample " << n << ", geoms " << g1 << " and " << g2;
        ++pairs;
        tight += dist > 0 && bound > dist - 0.01;
      }
  }
  EXPECT_GT(tight, pairs / 4) << "the bound is within 1 cm of the distance often enough to matter";
  mj_deleteData(d);
  mj_deleteModel(m);
}

TEST(Sleeping, AnObjectAtRestSleepsAndWakesBeforeAFallingOneReachesIt) {
  auto w = SimWorld::load("scenes/bin_table.xml", panda(), cubes(2));
  w->setObjectPose(0, makePose(Vec3(0.5, -0.25, 0.036), Quat::Identity()));
  w->setObjectPose(1, makePose(Vec3(0.6, -0.3, 0.036), Quat::Identity()));
  const VecX zero = VecX::Zero(7);
  auto hold = [&](double seconds) {
    for (int k = 0; k < static_cast<int>(seconds / kControlPeriod); ++k)
      w->stepServo(panda().home(), zero, zero, 0.04, 40);
  };
  hold(0.5);
  ASSERT_TRUE(w->objectAsleep(0));
  ASSERT_TRUE(w->objectAsleep(1));
  const Vec3 rest = w->object(0).T_world_object.translation();
  // Cube 1 dropped from 4 cm above cube 0: it must land on it, not fall through.
  w->setObjectPose(1, makePose(rest + Vec3(0, 0, 0.09), Quat::Identity()));
  EXPECT_FALSE(w->objectAsleep(1)) << "moved by hand: awake";
  bool woke = false;
  for (int k = 0; k < 200; ++k) {
    w->stepServo(panda().home(), zero, zero, 0.04, 40);
    woke = woke || !w->objectAsleep(0);
  }
  EXPECT_TRUE(woke);
  const Vec3 top = w->object(1).T_world_object.translation();
  EXPECT_NEAR(top.z(), rest.z() + 0.05, 0.002) << "resting on cube 0";
  EXPECT_LT((w->object(0).T_world_object.translation() - rest).norm(), 0.002);
  // Resting on another object is not resting on the world (friction holds a stack or a lean,
  // and MuJoCo's soft contacts let it creep): the stack stays awake, and stays put.
  hold(0.5);
  EXPECT_FALSE(w->objectAsleep(0));
  EXPECT_FALSE(w->objectAsleep(1));
  EXPECT_NEAR(w->object(1).T_world_object.translation().z(), top.z(), 0.001);
  // Moved onto the floor beside it, cube 1 comes to rest there, and both sleep.
  w->setObjectPose(1, makePose(Vec3(0.6, -0.3, 0.036), Quat::Identity()));
  hold(0.5);
  EXPECT_TRUE(w->objectAsleep(0));
  EXPECT_TRUE(w->objectAsleep(1));
  // With sleeping off every object is awake.
  PhysicsOptions off;
  off.sleep = false;
  w->setPhysics(off, "test");
  EXPECT_FALSE(w->objectAsleep(0));
  EXPECT_FALSE(w->objectAsleep(1));
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// A scene in MuJoCo's default angle unit (degrees) gets the robot's joint ranges in degrees; a
// scene in radians, as written. The robot's own <compiler> is left out (the scene's rules).
TEST(SceneCompose, JointRangesFollowTheScenesAngleUnit) {
  const RobotModel& robot = RobotModel::load("robots/panda/panda.yaml");
  const std::string radians = composeScene("scenes/bin_table.xml", robot.spec(), {});
  EXPECT_THAT(radians, ::testing::HasSubstr("range=\"-1.7628 1.7628\""));
  std::stringstream s;
  s << std::ifstream("scenes/bin_table.xml").rdbuf();
  std::string xml = s.str();
  xml.replace(xml.find("angle=\"radian\""), 14, "");
  const std::string path = ::testing::TempDir() + "/degree_scene.xml";
  std::ofstream(path) << xml;
  const std::string degrees = composeScene(path, robot.spec(), {});
  EXPECT_THAT(degrees, ::testing::HasSubstr("range=\"-101.001"));
  EXPECT_THAT(degrees, ::testing::HasSubstr("range=\"0 0.04\""));  // a finger's slide: metres
  EXPECT_EQ(degrees.find("<compiler angle=\"radian\"/>"), std::string::npos);
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// A scene whose robot_mount stands 10 cm ahead, 5 cm to the right and turned 20 deg: the composed
// model's frame is the robot's base, so the scene's sites are where the inverse mount puts them,
// the static parts still count as the world's (collisions), and the parked objects are moved too.
TEST(SceneCompose, AMovedMountMovesTheSceneIntoTheBaseFrame) {
  std::stringstream s;
  s << std::ifstream("scenes/bin_table.xml").rdbuf();
  std::string xml = s.str();
  const std::string mount = "<site name=\"robot_mount\" pos=\"0 0 0\"";
  ASSERT_NE(xml.find(mount), std::string::npos);
  const double yaw = 20 * M_PI / 180;
  xml.replace(xml.find(mount), mount.size(),
              "<site name=\"robot_mount\" pos=\"0.1 -0.05 0\" quat=\"" + std::to_string(std::cos(yaw / 2)) + " 0 0 " +
                  std::to_string(std::sin(yaw / 2)) + "\"");
  const std::string path = ::testing::TempDir() + "/moved_mount.xml";
  std::ofstream(path) << xml;
  auto plain = SimWorld::load("scenes/bin_table.xml", panda(), cubes(3));
  auto moved = SimWorld::load(path, panda(), cubes(3));
  ASSERT_EQ(moved->numObjects(), 3);
  const Pose M = makePose(Vec3(0.1, -0.05, 0), Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix());
  for (const char* site : {"bin_region", "place_target"}) {
    const Pose expected = M.inverse() * plain->site(site).first;
    EXPECT_LT((moved->site(site).first.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-6) << site;
  }
  for (int i = 0; i < plain->numObjects(); ++i) {
    const Vec3 expected = M.inverse() * plain->object(i).T_world_object.translation();
    EXPECT_LT((moved->object(i).T_world_object.translation() - expected).norm(), 1e-6) << i;
  }
  // The arm driven into the table: a collision with the world's static parts, as in the plain scene.
  VecX q = panda().home();
  q[1] = 1.7;
  q[3] = -0.3;
  for (auto* w : {plain.get(), moved.get()}) {
    w->setArm(q);
    w->stepKinematic();
    EXPECT_GT(w->collisionEvents(), 0);
  }
}

TEST(SceneCompose, AMountTiltedOffTheVerticalIsRefused) {
  std::stringstream s;
  s << std::ifstream("scenes/bin_table.xml").rdbuf();
  std::string xml = s.str();
  const std::string mount = "<site name=\"robot_mount\" pos=\"0 0 0\"";
  xml.replace(xml.find(mount), mount.size(), "<site name=\"robot_mount\" pos=\"0 0 0\" euler=\"0.1 0 0\"");
  const std::string path = ::testing::TempDir() + "/tilted_mount.xml";
  std::ofstream(path) << xml;
  try {
    SimWorld::load(path, panda());
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("the base may turn about z only"));
  }
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// The composed scene is compiled from memory under the scene's own folder: its relative asset paths
// (here a mesh) resolve as they would for the file, whatever the working directory.
TEST(SceneCompose, AScenesRelativeAssetPathsResolveAgainstItsFolder) {
  const std::string dir = ::testing::TempDir() + "/asset_scene";
  std::filesystem::create_directories(dir + "/meshes");
  {
    std::ofstream stl(dir + "/meshes/tetra.stl", std::ios::binary);  // binary STL, 4 facets
    const float v[4][3][3] = {{{0, 0, 0}, {0.05f, 0, 0}, {0, 0.05f, 0}}, {{0, 0, 0}, {0, 0.05f, 0}, {0, 0, 0.05f}},
                              {{0, 0, 0}, {0, 0, 0.05f}, {0.05f, 0, 0}}, {{0.05f, 0, 0}, {0, 0, 0.05f}, {0, 0.05f, 0}}};
    const char header[80] = {};
    const uint32_t n = 4;
    const float normal[3] = {0, 0, 0};
    const uint16_t attr = 0;
    stl.write(header, 80).write(reinterpret_cast<const char*>(&n), 4);
    for (const auto& tri : v) {
      stl.write(reinterpret_cast<const char*>(normal), 12).write(reinterpret_cast<const char*>(tri), 36);
      stl.write(reinterpret_cast<const char*>(&attr), 2);
    }
  }
  std::stringstream s;
  s << std::ifstream("scenes/bin_table.xml").rdbuf();
  std::string xml = s.str();
  xml.replace(xml.find("<default>"), 9, "<asset><mesh name=\"tetra_mesh\" file=\"meshes/tetra.stl\"/></asset>\n  <default>");
  xml.replace(xml.find("<worldbody>"), 11, "<worldbody>\n    <geom name=\"tetra_geom\" type=\"mesh\" mesh=\"tetra_mesh\" pos=\"-0.6 0.6 0.01\"/>");
  std::ofstream(dir + "/scene.xml") << xml;
  EXPECT_NO_THROW(SimWorld::load(dir + "/scene.xml", panda()));
}

}  // namespace
}  // namespace mm
