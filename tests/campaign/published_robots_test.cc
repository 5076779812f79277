// Robots as their makers publish them (tests/robot/published/: the files unedited, their licences
// beside them) run the quickstart task with only the experiment's robot: and gripper: keys. What
// the loader chose (the flange, a home found above the bin) is printed and recorded; what it
// changed of the files is said. A robot whose home is not clear of the scene is exit 2 naming the
// colliding pair, before any trial; `minimanip check` says the same without running one.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <tuple>

#include "cli_helpers.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using namespace testing_cli;

struct Published {
  const char* file;
  const char* flange;  // as printed: name (how it was chosen)
  const char* note;    // one thing said of the file
};

class PublishedRobot : public ::testing::TestWithParam<Published> {};

TEST_P(PublishedRobot, RunsTheQuickstartUneditedWithOnlyRobotAndGripper) {
  const Published p = GetParam();
  TempDir d;
  const RunResult r = runMinimanip(std::string("run experiments/ur5e_quickstart.yaml --trials 3 --set robot=") + p.file +
                                   " --set gripper=robots/grippers/robotiq_2f85.yaml --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr(std::string("flange ") + p.flange));
  EXPECT_THAT(r.out, HasSubstr("(computed: none given; the clear gripper-down pose above the bin farthest from the limits)"));
  EXPECT_THAT(r.out, HasSubstr(p.note));
  const auto trials = readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 3u);
  for (const auto& t : trials) EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
  // The choices are recorded with the results (as comments: they are not experiment keys).
  std::ifstream in(d.path() / "out" / "config.resolved.yaml");
  const std::string resolved((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(resolved, HasSubstr(std::string("# robot ")));
  EXPECT_THAT(resolved, HasSubstr(std::string("flange ") + p.flange));
  EXPECT_THAT(resolved, HasSubstr("# home ["));
}

// `minimanip check`: the same choices, and the cell's dry run, without a trial.
TEST_P(PublishedRobot, CheckSaysHowItWasReadAndWhatItReaches) {
  const Published p = GetParam();
  const RunResult r = runMinimanip(std::string("check experiments/ur5e_quickstart.yaml --set robot=") + p.file +
                                   " --set gripper=robots/grippers/robotiq_2f85.yaml");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr(std::string("flange ") + p.flange));
  EXPECT_THAT(r.out, HasSubstr("gripper robotiq_2f85 (robots/grippers/robotiq_2f85.yaml) on the flange"));
  EXPECT_THAT(r.out, HasSubstr("IK solver dls (kinematics.solver auto: the robot declares no closed form, so the numerical dls)"));
  EXPECT_THAT(r.out, HasSubstr("home clear of the scene, "));
  EXPECT_THAT(r.out, ::testing::ContainsRegex("reach over the bin: [0-9]+ of 50"));
  EXPECT_THAT(r.out, HasSubstr("reach over the place target: 18 of 18 (100%) gripper-down poses have an IK solution"));
}

INSTANTIATE_TEST_SUITE_P(
    Makers, PublishedRobot,
    ::testing::Values(
        Published{"tests/robot/published/ur5e/ur5e.urdf", "tool0 (a frame fixed after the last joint, named like a tool frame)",
                  "ur5e_robot"},
        Published{"tests/robot/published/panda_moveit/moveit_resources_panda_description/urdf/panda.urdf",
                  "panda_hand (the link the robot file's own hand hangs from)",
                  "note: the links below the flange 'panda_hand' (panda_leftfinger, panda_rightfinger) are left out"},
        Published{"tests/robot/published/xarm6/xarm6_robot.urdf", "link6 (the last link the arm's joints turn)",
                  "note: link 'link2': its principal moments of inertia"}),
    [](const ::testing::TestParamInfo<Published>& i) { return std::string(i.index == 0 ? "ur5e" : i.index == 1 ? "panda" : "xarm6"); });

TEST(PublishedRobots, ThePandaWithoutItsCompanionSaysWhatItLacksAndTheKeyThatGivesIt) {
  TempDir d;
  fs::copy("tests/robot/published/panda_moveit", d.path() / "panda_moveit", fs::copy_options::recursive);
  const fs::path urdf = d.path() / "panda_moveit/moveit_resources_panda_description/urdf/panda.urdf";
  fs::remove(urdf.string() + ".yaml");
  const RunResult r = runMinimanip("run experiments/ur5e_quickstart.yaml --trials 1 --set robot=" + urdf.string() +
                                   " --set gripper=robots/grippers/robotiq_2f85.yaml --out " + (d.path() / "out").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr(urdf.string() + ": link 'panda_link1' has no mass"));
  EXPECT_THAT(r.out, HasSubstr("default_link_mass: <kg> in " + urdf.string() + ".yaml"));
  EXPECT_FALSE(fs::exists(d.path() / "out" / "trials.jsonl"));
}

TEST(PublishedRobots, CheckNamesTheClosedFormOfAnArmThatDeclaresOne) {
  const RunResult r = runMinimanip("check experiments/quickstart.yaml");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("IK solver analytic (kinematics.solver auto: the robot's closed form 'panda')"));
  EXPECT_THAT(r.out, HasSubstr("home [0, -0.7854, 0, -2.356, 0, 1.571, 0.7854] (the robot's files)"));
}

TEST(PublishedRobots, AHomeThatIsNotClearOfTheSceneIsExitTwoNamingTheCollidingPair) {
  TempDir d;
  std::ifstream in("robots/ur5e/ur5e.yaml");
  std::string arm((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"home: [0.449324, -1.60236, -1.149, 1.18056, -1.570796, 2.02012]",
                                                                     "home: [0, 1.0, 0, 0, 0, 0]"},
                                 {"gripper: ../grippers/", "gripper: " + (fs::current_path() / "robots/grippers/").string()}}) {
    const auto pos = arm.find(from);
    ASSERT_NE(pos, std::string::npos) << from;
    arm.replace(pos, from.size(), to);
  }
  const std::string robot = d.file("arm.yaml", arm);
  const RunResult r = runMinimanip("run experiments/ur5e_quickstart.yaml --trials 1 --set robot=" + robot + " --out " +
                                   (d.path() / "out").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr(robot + ": home [0, 1, 0, 0, 0, 0] is not clear of the scene"));
  EXPECT_THAT(r.out, HasSubstr("ur5e_upper_arm / table"));
  EXPECT_FALSE(fs::exists(d.path() / "out" / "trials.jsonl"));
  const RunResult c = runMinimanip("check experiments/ur5e_quickstart.yaml --set robot=" + robot);
  EXPECT_EQ(c.code, 2) << c.out;
  EXPECT_THAT(c.out, HasSubstr("ur5e_upper_arm / table"));
}

// MuJoCo's complaint about a robot names the robot's file and its link, not the composed scene.
TEST(PublishedRobots, MujocosComplaintAboutARobotNamesTheRobotsFileAndLink) {
  TempDir d;
  auto slurpFile = [](const std::string& f) {
    std::ifstream in(f);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  std::string urdf = slurpFile("robots/panda/panda.urdf");
  std::string companion = slurpFile("robots/panda/panda.urdf.yaml");
  for (auto [text, from, to] : {std::tuple<std::string*, std::string, std::string>{&urdf, "<mass value=\"4.97\"/>", "<mass value=\"1e-30\"/>"},
                                {&urdf, "ixx=\"0.0442252340498\" ixy=\"0\" ixz=\"0\" iyy=\"0.0387044437423\" iyz=\"0\" izz=\"0.0169528796659\"",
                                 "ixx=\"1e-30\" ixy=\"0\" ixz=\"0\" iyy=\"1e-30\" iyz=\"0\" izz=\"1e-30\""},
                                {&companion, "gripper: ../grippers/", "gripper: " + (fs::current_path() / "robots/grippers/").string()}}) {
    const auto pos = text->find(from);
    ASSERT_NE(pos, std::string::npos) << from;
    text->replace(pos, from.size(), to);
  }
  const std::string robot = d.file("panda.urdf", urdf);
  d.file("panda.urdf.yaml", companion);
  const RunResult r = runMinimanip("run experiments/quickstart.yaml --trials 1 --set robot=" + robot + " --out " + (d.path() / "out").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr(robot + ": 'panda_link1': MuJoCo rejected the robot (mounted in scenes/bin_table.xml)"));
}

}  // namespace
}  // namespace mm
