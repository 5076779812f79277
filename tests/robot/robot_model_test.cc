// RobotModel (URDF via urdfdom, our FK) against MuJoCo's kinematics of the generated MJCF.
#include "robot/robot_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <filesystem>
#include <set>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/rng.h"
#include "robot/description_writer.h"
#include "sim/mjcf_robot.h"

namespace mm {
namespace {

const std::string kSpec = "robots/panda/panda.yaml";

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

VecX randomConfig(const RobotModel& m, Rng& rng) {
  VecX q(m.dof());
  for (int i = 0; i < m.dof(); ++i) q[i] = rng.uniform(m.lower()[i], m.upper()[i]);
  return q;
}

class EveryRobot : public ::testing::TestWithParam<std::string> {};
INSTANTIATE_TEST_SUITE_P(RobotDescription, EveryRobot, ::testing::Values("robots/panda/panda.yaml", "robots/ur5e/ur5e.yaml"),
                         [](const auto& p) { return std::filesystem::path(p.param).stem().string(); });

TEST_P(EveryRobot, CommittedFilesMatchTheGenerator) {
  const RobotSpec spec = loadRobotSpec(GetParam());
  EXPECT_EQ(slurp(spec.mjcfPath()), writeMjcf(spec)) << "run: build/gen_robot " << GetParam();
  EXPECT_EQ(slurp(spec.urdfPath()), writeUrdf(spec)) << "run: build/gen_robot " << GetParam();
}

// 100 random configurations (seed 11): every link frame and the TCP of the URDF model agree with
// MuJoCo's forward kinematics of the MJCF within 1e-9.
TEST_P(EveryRobot, MjcfAndUrdfForwardKinematicsAgree) {
  const RobotModel robot = RobotModel::load(GetParam());
  char err[1000] = "";
  mjModel* m = mj_loadXML(robot.spec().mjcfPath().c_str(), nullptr, err, sizeof err);
  ASSERT_NE(m, nullptr) << err;
  mjData* d = mj_makeData(m);
  const int tcp = mj_name2id(m, mjOBJ_SITE, robot.spec().tip_link.c_str());
  ASSERT_GE(tcp, 0);
  Rng rng(11);
  std::vector<Pose> links;
  double worst = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const VecX q = randomConfig(robot, rng);
    const double opening = rng.uniform(0, robot.spec().gripper.travel);
    for (int i = 0; i < robot.dof(); ++i) d->qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, robot.jointNames()[i].c_str())]] = q[i];
    for (const std::string& finger : robot.spec().gripper.finger_joints)
      d->qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, finger.c_str())]] = opening;
    mj_kinematics(m, d);
    const Pose T = robot.fk(q);
    for (int k = 0; k < 3; ++k) {
      worst = std::max(worst, std::abs(T.translation()[k] - d->site_xpos[3 * tcp + k]));
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(T.linear()(k, c) - d->site_xmat[9 * tcp + 3 * k + c]));
    }
    robot.linkPoses(q, opening, links);
    for (size_t l = 0; l < robot.links().size(); ++l) {
      const int b = mj_name2id(m, mjOBJ_BODY, robot.links()[l].name.c_str());
      if (b < 0) continue;  // the TCP is a site in MJCF
      for (int k = 0; k < 3; ++k) {
        worst = std::max(worst, std::abs(links[l].translation()[k] - d->xpos[3 * b + k]));
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(links[l].linear()(k, c) - d->xmat[9 * b + 3 * k + c]));
      }
    }
  }
  EXPECT_LT(worst, 1e-9);
  mj_deleteData(d);
  mj_deleteModel(m);
}

TEST(RobotModel, LimitsComeFromTheSpec) {
  const RobotModel robot = RobotModel::load(kSpec);
  ASSERT_EQ(robot.dof(), 7);
  EXPECT_DOUBLE_EQ(robot.vmax()[0], 2.175);
  EXPECT_DOUBLE_EQ(robot.vmax()[6], 2.61);
  EXPECT_DOUBLE_EQ(robot.amax()[1], 7.5);
  EXPECT_DOUBLE_EQ(robot.jmax()[6], 10000.0);
  EXPECT_DOUBLE_EQ(robot.lower()[3], -3.0718);
  EXPECT_DOUBLE_EQ(robot.upper()[5], 3.7525);
  EXPECT_TRUE(robot.withinLimits(robot.home()));
  // The Panda's "ready" pose puts the TCP 0.307 m ahead, 0.487 m up, pointing down.
  const Pose T = robot.fk(robot.home());
  EXPECT_NEAR(T.translation().x(), 0.3069, 1e-3);
  EXPECT_NEAR(T.translation().y(), 0.0, 1e-9);
  EXPECT_NEAR(T.translation().z(), 0.4869, 1e-3);
  EXPECT_NEAR(T.linear()(2, 2), -1.0, 1e-6);
}

TEST_P(EveryRobot, JacobianMatchesFiniteDifferences) {  // seed 5, 20 configurations
  const RobotModel robot = RobotModel::load(GetParam());
  Rng rng(5);
  Jacobian J;
  for (int t = 0; t < 20; ++t) {
    const VecX q = randomConfig(robot, rng);
    robot.jacobian(q, J);
    const Pose T0 = robot.fk(q);
    for (int i = 0; i < robot.dof(); ++i) {
      VecX qh = q;
      const double h = 1e-7;
      qh[i] += h;
      const Pose T1 = robot.fk(qh);
      const Vec3 v = (T1.translation() - T0.translation()) / h;
      const Eigen::AngleAxisd aa(T1.linear() * T0.linear().transpose());
      const Vec3 w = aa.axis() * aa.angle() / h;
      EXPECT_LT((v - J.block<3, 1>(0, i)).norm(), 1e-5);
      EXPECT_LT((w - J.block<3, 1>(3, i)).norm(), 1e-5);
    }
  }
}

class BadRobotFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("mm_badrobot_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_ / "grippers");
    std::filesystem::copy_file("robots/panda/panda.yaml", dir_ / "panda.yaml");
    std::filesystem::copy_file("robots/grippers/panda_hand.yaml", dir_ / "grippers" / "panda_hand.yaml");
    replaceIn("panda.yaml", "gripper: ../grippers/panda_hand.yaml", "gripper: grippers/panda_hand.yaml");
    std::filesystem::copy_file("robots/panda/panda.urdf", dir_ / "panda.urdf");
    std::filesystem::copy_file("robots/panda/panda.urdf.yaml", dir_ / "panda.urdf.yaml");
    replaceIn("panda.urdf.yaml", "gripper: ../grippers/panda_hand.yaml", "gripper: grippers/panda_hand.yaml");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  void replaceIn(const std::string& file, const std::string& from, const std::string& to) {
    std::string s = slurp((dir_ / file).string());
    const auto pos = s.find(from);
    ASSERT_NE(pos, std::string::npos);
    s.replace(pos, from.size(), to);
    std::ofstream((dir_ / file).string()) << s;
  }
  std::string loadError(const std::string& file = "panda.yaml") {
    try {
      RobotModel::load((dir_ / file).string());
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  std::filesystem::path dir_;
};

TEST_F(BadRobotFiles, TheCopiesLoad) {
  EXPECT_EQ(loadError("panda.yaml"), "");
  EXPECT_EQ(loadError("panda.urdf"), "");
}

TEST_F(BadRobotFiles, MalformedUrdfNamesFileAndLine) {
  replaceIn("panda.urdf", "<link name=\"panda_link3\">", "<link name=\"panda_link3\"");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::MatchesRegex(".*panda\\.urdf:[0-9]+: malformed XML.*"));
}

TEST_F(BadRobotFiles, UrdfMissingLinkIsRejected) {
  replaceIn("panda.urdf", "<child link=\"panda_link4\"/>", "<child link=\"panda_nolink\"/>");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::HasSubstr("panda.urdf: not a valid URDF"));
}

TEST_F(BadRobotFiles, UrdfCycleIsRejected) {
  // panda_link2 made the child of panda_link4 too: two parents, a cycle.
  replaceIn("panda.urdf", "<joint name=\"panda_joint5\" type=\"revolute\">\n    <parent link=\"panda_link4\"/>\n    <child link=\"panda_link5\"/>",
            "<joint name=\"panda_joint5\" type=\"revolute\">\n    <parent link=\"panda_link4\"/>\n    <child link=\"panda_link2\"/>");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::MatchesRegex(".*panda\\.urdf:[0-9]+: not a valid URDF robot description: link "
                                                                 "'panda_link2' is the child of two joints, 'panda_joint2' and 'panda_joint5'.*"));
}

TEST_F(BadRobotFiles, UrdfBadLimitsAreRejected) {
  replaceIn("panda.urdf", "<limit lower=\"-1.7628\" upper=\"1.7628\"", "<limit lower=\"1.7628\" upper=\"-1.7628\"");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::HasSubstr("joint 'panda_joint2': expected <limit lower < upper>"));
}

TEST_F(BadRobotFiles, UrdfMeshesDaeAndUnresolvedPackagesAreRejected) {
  const std::string cyl = "<geometry><cylinder radius=\"0.09\" length=\"0.14\"/></geometry>";
  replaceIn("panda.urdf", cyl, "<geometry><mesh filename=\"meshes/link0.dae\"/></geometry>");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::HasSubstr("link0.dae' is COLLADA (.dae), which MuJoCo 2.2 cannot read"));
  replaceIn("panda.urdf", "meshes/link0.dae", "package://franka_description/meshes/link0.stl");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::HasSubstr("panda.urdf: link 'panda_link0': cannot resolve 'package://franka_description/meshes/link0.stl'"));
  replaceIn("panda.urdf", "package://franka_description/meshes/link0.stl", "meshes/none.stl");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::HasSubstr("cannot read mesh"));
}

TEST_F(BadRobotFiles, XacroIsRefusedWithWhereXacroComesFrom) {
  std::filesystem::copy_file(dir_ / "panda.urdf", dir_ / "panda.urdf.xacro");
  EXPECT_THAT(loadError("panda.urdf.xacro"), ::testing::HasSubstr("panda.urdf.xacro: a .xacro file is a template of a URDF: run xacro first"));
  EXPECT_THAT(loadError("panda.urdf.xacro"), ::testing::HasSubstr("not in Debian 12"));
  replaceIn("panda.urdf", "<link name=\"panda_link3\">", "<xacro:property name=\"r\" value=\"1\"/>\n<link name=\"panda_link3\">");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::HasSubstr("panda.urdf: this URDF still holds xacro macros"));
}

TEST_F(BadRobotFiles, MjcfWithoutVelocitiesTakesACautiousOneSaidAndTwoHingesInABodyAreRejected) {
  std::filesystem::copy_file("robots/panda/panda.xml", dir_ / "panda.xml");
  std::filesystem::copy_file("robots/panda/panda.xml.yaml", dir_ / "panda.xml.yaml");
  replaceIn("panda.xml.yaml", "gripper: ../grippers/panda_hand.yaml", "gripper: grippers/panda_hand.yaml");
  auto mjcfError = [&] {
    try {
      loadAnyRobot((dir_ / "panda.xml").string());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(mjcfError(), "");
  replaceIn("panda.xml.yaml", "velocity: [", "# velocity: [");
  EXPECT_EQ(mjcfError(), "");
  {
    const RobotModel r = loadAnyRobot((dir_ / "panda.xml").string());
    EXPECT_DOUBLE_EQ(r.vmax()[0], 1.5);
    EXPECT_THAT(r.spec().notes, ::testing::Contains(::testing::HasSubstr("MJCF has no joint velocity limits: 1.5 rad/s each assumed")));
  }
  replaceIn("panda.xml.yaml", "# velocity: [", "velocity: [");
  replaceIn("panda.xml", "<joint name=\"panda_joint3\"", "<joint name=\"panda_joint3b\" axis=\"1 0 0\"/>\n<joint name=\"panda_joint3\"");
  EXPECT_THAT(mjcfError(), ::testing::HasSubstr("body 'panda_link3' on the arm's chain must hold one hinge joint"));
}

// MJCF robot files as published: the settings of a simulation of their own (<option>, newer
// compiler settings) are left out and said; a keyword MuJoCo 2.2 lacks is named with its fix and the
// file's own line; the file's keyframe 'home' is the home when the companion gives none.
TEST_F(BadRobotFiles, MjcfSettingsOfItsOwnSimulationAreLeftOutAndSaid) {
  std::filesystem::copy_file("robots/panda/panda.xml", dir_ / "panda.xml");
  std::filesystem::copy_file("robots/panda/panda.xml.yaml", dir_ / "panda.xml.yaml");
  replaceIn("panda.xml.yaml", "gripper: ../grippers/panda_hand.yaml", "gripper: grippers/panda_hand.yaml");
  // MuJoCo 2.2 refuses integrator="implicitfast" (2.3.3's) and alignfree (3's).
  replaceIn("panda.xml", "<compiler angle=\"radian\"/>",
            "<compiler angle=\"radian\" alignfree=\"true\"/>\n  <option integrator=\"implicitfast\" timestep=\"0.001\"/>");
  const RobotModel r = loadAnyRobot((dir_ / "panda.xml").string());
  EXPECT_EQ(r.dof(), 7);
  EXPECT_THAT(r.spec().notes, ::testing::Contains(::testing::HasSubstr("its <option> (line 4) is left out")));
  EXPECT_THAT(r.spec().notes, ::testing::Contains(::testing::HasSubstr("its <compiler alignfree> (line 3) is left out")));
}

TEST_F(BadRobotFiles, AMjcfKeywordNewerThanMujoco22IsNamedWithItsFixAndTheFilesOwnLine) {
  std::filesystem::copy_file("robots/panda/panda.xml", dir_ / "panda.xml");
  std::filesystem::copy_file("robots/panda/panda.xml.yaml", dir_ / "panda.xml.yaml");
  replaceIn("panda.xml.yaml", "gripper: ../grippers/panda_hand.yaml", "gripper: grippers/panda_hand.yaml");
  replaceIn("panda.xml", "<actuator>", "<option timestep=\"0.001\"/>\n  <actuator>\n    <position name=\"p1\" joint=\"panda_joint1\" kp=\"100\" kv=\"10\"/>");
  std::string err;
  try {
    loadAnyRobot((dir_ / "panda.xml").string());
  } catch (const InputError& e) {
    err = e.what();
  }
  EXPECT_THAT(err, ::testing::HasSubstr((dir_ / "panda.xml").string() + ":95: MuJoCo rejected the robot"));
  EXPECT_THAT(err, ::testing::HasSubstr("line 95"));
  EXPECT_THAT(err, ::testing::HasSubstr("MuJoCo 2.2 lacks it: <position kv> is MuJoCo 2.3's: remove kv"));
}

TEST_F(BadRobotFiles, TheMjcfKeyframeHomeIsTheHomeWhenTheCompanionGivesNone) {
  std::filesystem::copy_file("robots/panda/panda.xml", dir_ / "panda.xml");
  std::filesystem::copy_file("robots/panda/panda.xml.yaml", dir_ / "panda.xml.yaml");
  replaceIn("panda.xml.yaml", "gripper: ../grippers/panda_hand.yaml", "gripper: grippers/panda_hand.yaml");
  replaceIn("panda.xml.yaml", "home: [", "# home: [");
  // Nine entries: the arm's seven, then the hand's two fingers (ignored).
  replaceIn("panda.xml", "<actuator>", "<keyframe>\n    <key name=\"home\" qpos=\"0.1 -0.5 0 -2 0 1.5 0.7 0.04 0.04\"/>\n  </keyframe>\n  <actuator>");
  const RobotModel r = loadAnyRobot((dir_ / "panda.xml").string());
  EXPECT_EQ(r.spec().home_source, "keyframe");
  EXPECT_NEAR(r.home()[0], 0.1, 1e-12);
  EXPECT_NEAR(r.home()[3], -2.0, 1e-12);
  EXPECT_NEAR(r.home()[6], 0.7, 1e-12);
  replaceIn("panda.xml.yaml", "# home: [", "home: [");  // the companion's wins
  EXPECT_EQ(loadAnyRobot((dir_ / "panda.xml").string()).spec().home_source, "yaml");
}

// A robot file that carries its own hand: the flange is where the hand hangs, and the hand is
// left out (the gripper is a part of its own), said.
TEST_F(BadRobotFiles, TheHandAnMjcfCarriesIsLeftOutAndItsMountIsTheFlange) {
  std::filesystem::copy_file("robots/panda/panda.xml", dir_ / "panda.xml");
  std::filesystem::copy_file("robots/panda/panda.xml.yaml", dir_ / "panda.xml.yaml");
  replaceIn("panda.xml.yaml", "gripper: ../grippers/panda_hand.yaml", "gripper: grippers/panda_hand.yaml");
  for (const char* key : {"flange_link: panda_link7", "flange_d: 0.107", "hand_yaw: -0.785398163397448"}) replaceIn("panda.xml.yaml", key, "");
  const RobotModel chosen = loadAnyRobot((dir_ / "panda.xml").string());
  EXPECT_EQ(chosen.spec().flange_link, "panda_hand");
  EXPECT_EQ(chosen.spec().flange_choice, "the body the robot file's own hand hangs from");
  EXPECT_THAT(chosen.spec().notes, ::testing::Contains(::testing::HasSubstr("below the flange 'panda_hand'")));
  // The same mount as the companion's flange_link, flange_d and hand_yaw said it.
  const RobotModel told = loadAnyRobot("robots/panda/panda.xml");
  const VecX q = told.home();
  EXPECT_LT((chosen.fk(q).translation() - told.fk(q).translation()).norm(), 1e-9);
  EXPECT_LT((chosen.fk(q).linear() - told.fk(q).linear()).norm(), 1e-9);
}

TEST_F(BadRobotFiles, AZeroJointAxisInAUrdfIsNamed) {
  replaceIn("panda.urdf", "<axis xyz=\"0 0 1\"/>", "<axis xyz=\"0 0 0\"/>");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::HasSubstr("panda.urdf: joint 'panda_joint1': <axis xyz> is zero (expected a direction)"));
}

// A root link named world, with one fixed child, is the world: the child is the base, and a
// massless base is static, not an error. Inertias violating A + B >= C are balanced and said.
TEST_F(BadRobotFiles, ARootLinkNamedWorldIsTheWorldAndAnUnphysicalInertiaIsBalancedAndSaid) {
  replaceIn("panda.urdf.yaml", "base_link: panda_link0", "");
  replaceIn("panda.urdf", "<link name=\"panda_link0\">",
            "<link name=\"world\"/>\n  <joint name=\"world_joint\" type=\"fixed\"><parent link=\"world\"/><child link=\"panda_link0\"/></joint>\n"
            "  <link name=\"panda_link0\">");
  replaceIn("panda.urdf", "<mass value=\"2.92\"/>", "<mass value=\"0\"/>");  // the base: massless
  replaceIn("panda.urdf", "<inertia ixx=\"0.0442252340498\" ixy=\"0\" ixz=\"0\" iyy=\"0.0387044437423\" iyz=\"0\" izz=\"0.0169528796659\"/>",
            "<inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.05\"/>");
  ASSERT_EQ(loadError("panda.urdf"), "");
  const RobotModel r = RobotModel::load((dir_ / "panda.urdf").string());
  EXPECT_EQ(r.spec().base_link, "panda_link0");
  EXPECT_EQ(r.spec().links[0].mass, 0.0);
  EXPECT_THAT(r.spec().notes, ::testing::Contains(::testing::HasSubstr("root link 'world' is the world")));
  EXPECT_THAT(r.spec().notes, ::testing::Contains(::testing::HasSubstr("link 'panda_link1': its principal moments of inertia (0.01, 0.01, 0.05 kg m^2) "
                                                                       "violate A + B >= C: balanced to 0.02333 each")));
  // The model MuJoCo compiles from it (the massless base without an inertial).
  char err[512] = "";
  const std::string xml = (dir_ / "written.xml").string();
  std::ofstream(xml) << writeMjcf(r.spec());
  mjModel* m = mj_loadXML(xml.c_str(), nullptr, err, sizeof err);
  EXPECT_NE(m, nullptr) << err;
  if (m) mj_deleteModel(m);
}

TEST_F(BadRobotFiles, UrdfCompanionUnknownKeyAndMissingGripper) {
  replaceIn("panda.urdf.yaml", "damping: 0.5", "dampin: 0.5");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::MatchesRegex(".*panda\\.urdf\\.yaml:[0-9]+:[0-9]+: unknown key 'dampin'.*"));
  replaceIn("panda.urdf.yaml", "dampin: 0.5", "damping: 0.5");
  replaceIn("panda.urdf.yaml", "gripper: grippers/panda_hand.yaml", "");
  EXPECT_THAT(loadError("panda.urdf"), ::testing::HasSubstr("no gripper"));
}

TEST_F(BadRobotFiles, MissingGripperFileIsNamed) {
  replaceIn("panda.yaml", "gripper: grippers/panda_hand.yaml", "gripper: grippers/none.yaml");
  EXPECT_THAT(loadError(), ::testing::HasSubstr("grippers/none.yaml: cannot open file (expected a gripper YAML)"));
}

TEST_F(BadRobotFiles, GripperValueOutOfRangeNamesLine) {
  replaceIn("grippers/panda_hand.yaml", "max_force: 70.0", "max_force: 0");
  EXPECT_THAT(loadError(), ::testing::MatchesRegex(".*panda_hand\\.yaml:[0-9]+:[0-9]+: 'max_force' must be > 0.*"));
}

TEST_F(BadRobotFiles, ANameUsedTwiceIsRejected) {
  replaceIn("grippers/panda_hand.yaml", "name: panda_leftfinger", "name: panda_link7");
  EXPECT_THAT(loadError(), ::testing::HasSubstr("the name 'panda_link7' is used twice"));
}

TEST_F(BadRobotFiles, SpecValueOutOfRangeNamesLine) {
  replaceIn("panda.yaml", "velocity: 2.6100", "velocity: -1");
  EXPECT_THAT(loadError(), ::testing::MatchesRegex(".*panda\\.yaml:[0-9]+:[0-9]+: 'velocity' must be > 0.*"));
}

TEST_F(BadRobotFiles, HomeOutsideLimits) {
  replaceIn("panda.yaml", "home: [0.0, -0.785398, 0.0, -2.356194", "home: [0.0, -0.785398, 0.0, 0.5");
  EXPECT_THAT(loadError(), ::testing::HasSubstr("outside the limits of panda_joint4"));
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// Outside robots/ (and a robot's own analytic IK) no code names a robot's links or joints: every
// link, joint and TCP name of every robot and gripper under robots/ is looked for, as a whole
// identifier, in every file under src/.
TEST(RobotNames, NoRobotLinkOrJointNameAppearsInTheSource) {
  namespace fs = std::filesystem;
  std::set<std::string> names;
  std::vector<std::string> robot_files, gripper_files;
  for (const auto& e : fs::recursive_directory_iterator("robots")) {
    const std::string inner = e.path().stem().extension().string();
    if (e.path().extension() != ".yaml" || inner == ".urdf" || inner == ".xml") continue;  // not a companion YAML
    (e.path().parent_path().filename() == "grippers" ? gripper_files : robot_files).push_back(e.path().string());
  }
  ASSERT_GE(robot_files.size(), 2u);
  ASSERT_GE(gripper_files.size(), 2u);
  for (const auto& r : robot_files)
    for (const auto& g : gripper_files) {
      const RobotSpec spec = loadRobotSpec(r, g);
      for (const auto& n : spec.names())
        if (n != spec.name && n != spec.gripper.name) names.insert(n);
    }
  ASSERT_GT(names.size(), 20u);
  auto ident = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  std::vector<std::string> hits;
  for (const auto& e : fs::recursive_directory_iterator("src")) {
    if (!e.is_regular_file()) continue;
    const std::string stem = e.path().stem().string();
    if (stem == "panda_analytic" || stem == "ur_analytic") continue;  // a robot's own analytic IK
    const std::string text = slurp(e.path().string());
    for (const auto& n : names)
      for (size_t p = text.find(n); p != std::string::npos; p = text.find(n, p + 1))
        if ((p == 0 || !ident(text[p - 1])) && (p + n.size() >= text.size() || !ident(text[p + n.size()])))
          hits.push_back(e.path().string() + ": " + n);
  }
  EXPECT_THAT(hits, ::testing::IsEmpty());
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

class PandaFrom : public ::testing::TestWithParam<std::string> {};
INSTANTIATE_TEST_SUITE_P(RobotFromFile, PandaFrom, ::testing::Values("robots/panda/panda.urdf", "robots/panda/panda.xml"),
                         [](const auto& p) { return std::filesystem::path(p.param).extension().string().substr(1); });

// The Panda from its URDF (panda.urdf + panda.urdf.yaml) or its MJCF (panda.xml + panda.xml.yaml)
// is the Panda from its YAML: the same chain, limits, home and analytic IK; FK equal within 1e-9
// over 200 random configurations.
TEST_P(PandaFrom, ItIsThePandaFromItsYaml) {
  const RobotModel a = RobotModel::load("robots/panda/panda.yaml");
  const RobotModel b = loadAnyRobot(GetParam());
  ASSERT_EQ(a.dof(), b.dof());
  EXPECT_EQ(a.jointNames(), b.jointNames());
  for (int i = 0; i < a.dof(); ++i) {
    EXPECT_NEAR(a.lower()[i], b.lower()[i], 1e-12);
    EXPECT_NEAR(a.upper()[i], b.upper()[i], 1e-12);
    EXPECT_NEAR(a.vmax()[i], b.vmax()[i], 1e-12);
    EXPECT_EQ(a.amax()[i], b.amax()[i]);
    EXPECT_EQ(a.jmax()[i], b.jmax()[i]);
    EXPECT_EQ(a.home()[i], b.home()[i]);
    EXPECT_TRUE(b.spec().joints[i].dh) << i;  // the DH form recognized from the URDF's origins
  }
  EXPECT_EQ(a.collisionShapes().size(), b.collisionShapes().size());  // capsules recognized
  EXPECT_EQ(b.spec().analytic_ik, "panda");
  EXPECT_EQ(a.links()[a.handLink()].name, b.links()[b.handLink()].name);
  Rng rng(21);
  double worst = 0;
  for (int t = 0; t < 200; ++t) {
    const VecX q = randomConfig(a, rng);
    worst = std::max(worst, (a.fk(q).matrix() - b.fk(q).matrix()).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-9);
}

}  // namespace
}  // namespace mm
