// End-to-end: the minimanip binary on short campaigns, determinism, and bad input.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cli_helpers.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;
using ::testing::MatchesRegex;
using namespace testing_cli;

std::string source(const std::string& rel) { return (fs::current_path() / rel).string(); }

TEST(Campaign, ShortMockCampaignSucceeds) {
  TempDir d;
  const RunResult r = runMinimanip("run experiments/quickstart.yaml --trials 5 --set hardware=mock --set progress=none --out " +
                                   (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 5u);
  for (const auto& t : trials) {
    EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
    EXPECT_EQ(t["collision_count"], 0);
    EXPECT_LT(t["place_position_error"].get<double>(), 1e-6);  // mock: objects move only with the hand
  }
  const json s = json::parse(std::ifstream(d.path() / "out" / "summary.json"));
  EXPECT_EQ(s["overall_yield"]["value"], 1.0);
  EXPECT_TRUE(fs::exists(d.path() / "out" / "config.resolved.yaml"));
  EXPECT_THAT(r.out, HasSubstr("Overall Yield:     100.0%"));
}

// Every trial placed its cube cleanly: no collision, stable physics, small place and tracking
// errors, the fingers stopped on the 5 cm cube, a plausible simulated time.
void expectCleanPicks(const std::vector<json>& trials) {
  for (const auto& t : trials) {
    EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
    EXPECT_EQ(t["collision_count"], 0);
    EXPECT_FALSE(t["sim_unstable"].get<bool>());
    EXPECT_LT(t["place_position_error"].get<double>(), 0.01);
    EXPECT_LT(t["max_tracking_error"].get<double>(), 0.01);
    EXPECT_GT(t["grasp_opening"].get<double>(), 0.02);
    EXPECT_GT(t["sim_time"].get<double>(), 3.0);
  }
}

// The summary leads with what the task asked: one object a trial (the others in the bin are
// context, not a yield), or the whole bin (the per-object yield first).
TEST(Campaign, TheSummarySaysWhatTheTaskAsked) {
  TempDir d;
  const std::string base = "run experiments/quickstart.yaml --set hardware=mock --set progress=none --trials 3 --seed 2";
  const RunResult one = runMinimanip(base + " --out " + (d.path() / "one").string());
  ASSERT_EQ(one.code, 0) << one.out;
  EXPECT_THAT(one.out, HasSubstr("Trials:            3 (each asked to place one object)"));
  EXPECT_THAT(one.out, HasSubstr("Objects placed:    3 (one a trial asked); "));
  EXPECT_THAT(one.out, ::testing::Not(HasSubstr("Object Yield")));
  const RunResult all = runMinimanip(base + " --set task.goal=clear_bin --out " + (d.path() / "all").string());
  ASSERT_EQ(all.code, 0) << all.out;
  EXPECT_THAT(all.out, ::testing::MatchesRegex("(.|\n)*Trials: +3 \\(each asked to clear its bin\\)\n  Object Yield: (.|\n)*"));
  EXPECT_EQ(json::parse(std::ifstream(d.path() / "all" / "summary.json"))["goal"], "clear_bin");
  EXPECT_EQ(json::parse(std::ifstream(d.path() / "one" / "summary.json"))["goal"], "pick_one");
}

TEST(Campaign, ShortMujocoCampaignSucceedsAndMeasures) {
  TempDir d;
  const RunResult r = runMinimanip("run experiments/quickstart.yaml --trials 4 --set progress=none --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 4u);
  expectCleanPicks(trials);
}

// Mixed shapes (experiments/mixed_shapes.yaml): boxes, tall cartons, flat packs, bottles and cans,
// 4-6 to a bin. Every trial places its object; each grasp selection is recorded candidate by
// candidate (scores, and why each dropped one was); picks carry their grasp type and the achieved
// grasp's deviation from the plan. Trials 2 and 9, with the hand's tilt free and the torque arm
// weighted up, are picked from the side (a box and a cylinder) and placed upright, the hand
// horizontal (trial 2's carton is picked from the side with the defaults too).
TEST(Campaign, MixedShapesArePickedTopDownAndFromTheSideAndRecordTheirGrasps) {
  TempDir d;
  RunResult r = runMinimanip("run experiments/mixed_shapes.yaml --trials 4 --set progress=none --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  r = runMinimanip("run experiments/mixed_shapes.yaml --trials 10 --only 2,9 --set grasp.tilt_weight=0 --set grasp.torque_weight=100 "
                   "--set progress=none --out " + (d.path() / "side").string());
  ASSERT_EQ(r.code, 0) << r.out;
  auto trials = readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 4u);
  const auto side = readTrials(d.path() / "side");
  ASSERT_EQ(side.size(), 2u);
  trials.insert(trials.end(), side.begin(), side.end());
  std::set<std::string> shapes;
  int side_picks = 0;
  for (const auto& t : trials) {
    EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
    ASSERT_FALSE(t["grasps"].empty());
    const auto& tried = t["grasps"].back()["tried"];
    ASSERT_FALSE(tried.empty());
    EXPECT_EQ(tried.back()["result"], "chosen");
    for (const auto& c : tried) {
      EXPECT_GT(c["closure_margin"].get<double>(), 0.0);
      EXPECT_GT(c["contact_area"].get<double>(), 0.0);
      if (c["result"] != "chosen") {
        EXPECT_FALSE(c["result"].get<std::string>().empty());
      }
    }
    shapes.insert(t["grasps"].back()["shape"].get<std::string>());
    ASSERT_EQ(t["picks"].size(), 1u);
    const auto& p = t["picks"][0];
    EXPECT_LT(p["grasp_deviation"].get<double>(), 0.003);
    EXPECT_LT(p["position_error"].get<double>(), 0.005);
    EXPECT_LT(p["orientation_error"].get<double>(), 3.0 * M_PI / 180);
    if (p["grasp_type"] == "side") ++side_picks;
  }
  EXPECT_EQ(shapes, (std::set<std::string>{"box", "cylinder"}));
  EXPECT_GE(side_picks, 2);
  for (const auto& t : side) EXPECT_EQ(t["picks"][0]["grasp_type"], "side") << t["trial"];
}

// The UR5e with a 2F-85-class gripper, by configuration only (experiments/ur5e_quickstart.yaml
// differs from the quickstart in its robot and gripper keys), on the quickstart's first trials.
TEST(Campaign, Ur5eWithA2f85ClassGripperPicksAndPlaces) {
  TempDir d;
  const RunResult r = runMinimanip("run experiments/ur5e_quickstart.yaml --trials 4 --set progress=none --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 4u);
  expectCleanPicks(trials);
  std::stringstream cfg;
  cfg << std::ifstream(d.path() / "out" / "config.resolved.yaml").rdbuf();
  EXPECT_THAT(cfg.str(), HasSubstr("robots/grippers/robotiq_2f85.yaml"));
}

// The Panda loaded from its URDF or its MJCF (each with its companion YAML) runs the quickstart's
// first trials with the outcomes of the Panda from its YAML: the same success, place errors within
// 0.2 mm.
TEST(Campaign, ThePandaFromItsUrdfOrMjcfPlacesAsFromItsYaml) {
  TempDir d;
  const std::string common = " --trials 4 --set progress=none --out ";
  ASSERT_EQ(runMinimanip("run experiments/quickstart.yaml" + common + (d.path() / "yaml").string()).code, 0);
  const auto a = readTrials(d.path() / "yaml");
  for (const std::string file : {"panda.urdf", "panda.xml"}) {
    const RunResult r = runMinimanip("run experiments/quickstart.yaml --set robot=robots/panda/" + file + common + (d.path() / file).string());
    ASSERT_EQ(r.code, 0) << r.out;
    const auto b = readTrials(d.path() / file);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i]["success"], b[i]["success"]) << file << " " << i;
      EXPECT_NEAR(a[i]["place_position_error"].get<double>(), b[i]["place_position_error"].get<double>(), 2e-4) << file << " " << i;
    }
  }
}

// A robot mounted 10 cm ahead, 5 cm to the right and turned 20 deg in the quickstart's scene picks
// and places as well. Trial 15 of seed 1 also checks that a plan starts where the previous one
// ended: there the lift's last IK sample lay 0.014 rad (null space) from the waypoint it was
// planned to, and the place plan, made from that waypoint, failed to start.
TEST(Campaign, AMovedMountPicksAndPlaces) {
  TempDir d;
  std::stringstream s;
  s << std::ifstream("scenes/bin_table.xml").rdbuf();
  std::string xml = s.str();
  const std::string mount = "<site name=\"robot_mount\" pos=\"0 0 0\"";
  ASSERT_NE(xml.find(mount), std::string::npos);
  xml.replace(xml.find(mount), mount.size(), "<site name=\"robot_mount\" pos=\"0.1 -0.05 0\" quat=\"0.984807753 0 0 0.173648178\"");
  const std::string scene = d.file("moved.xml", xml);
  const RunResult r = runMinimanip("run experiments/quickstart.yaml --trials 20 --only 0,1,15 --set progress=none --set scene=" + scene +
                                   " --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = readTrials(d.path() / "out");
  ASSERT_EQ(trials.size(), 3u);
  expectCleanPicks(trials);
}

// The benchmarks take a robot by name from any working directory: the UR5e's closed form on its
// random and near-singular poses (50 each, seed 1) solves every one.
TEST(Campaign, IkBenchTakesTheUr5eByNameFromAnyFolder) {
  TempDir d;
  const std::string cmd = "cd " + d.path().string() + " && " + MINIMANIP_BINARY +
                          " ik-bench --robot ur5e --poses 50 --seed 1 --sets random,singular --solvers analytic --out " +
                          (d.path() / "ik").string() + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const json j = json::parse(std::ifstream(d.path() / "ik" / "ik_bench.json"));
  EXPECT_THAT(j["robot"].get<std::string>(), HasSubstr("robots/ur5e/ur5e.yaml"));
  for (const char* set : {"random", "singular"}) EXPECT_EQ(j["sets"][set][0]["successes"], 50) << set;
}

// The clearing tree picks until the bin is empty, or until target_count objects are placed.
TEST(Campaign, ClearingEmptiesTheBinOrStopsAtTheCount) {
  TempDir d;
  const std::string common = " --trials 1 --set objects.drop=false --set objects.count_min=3 --set objects.count_max=3 "
                             "--set objects.wall_margin=0.07 --set objects.settle_time=0.3 --set progress=none --out ";
  const RunResult all = runMinimanip("run experiments/bin_clearing.yaml" + common + (d.path() / "all").string());
  ASSERT_EQ(all.code, 0) << all.out;
  const json a = readTrials(d.path() / "all").at(0);
  EXPECT_TRUE(a["success"].get<bool>()) << a.dump();
  EXPECT_EQ(a["objects_placed"], 3);
  EXPECT_EQ(a["objects_left_in_bin"], 0);
  EXPECT_EQ(a["reported_total"], 3);
  EXPECT_EQ(a["collision_count"], 0);

  std::string tree;
  {
    std::ifstream in("experiments/trees/bin_clearing.xml");
    tree.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string ten = "output_key=\"target_count\" value=\"10\"";
  ASSERT_NE(tree.find(ten), std::string::npos);
  tree.replace(tree.find(ten), ten.size(), "output_key=\"target_count\" value=\"2\"");
  const std::string two = d.file("two.xml", tree);
  const RunResult some = runMinimanip("run experiments/bin_clearing.yaml --set tree=" + two + common + (d.path() / "two").string());
  ASSERT_EQ(some.code, 0) << some.out;
  const json t = readTrials(d.path() / "two").at(0);
  EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
  EXPECT_EQ(t["objects_placed"], 2);
  EXPECT_EQ(t["objects_left_in_bin"], 1);
  EXPECT_EQ(t["reported_total"], 2);
}

// In camera mode the clearing tree looks again after a push from home, not with the hand still
// over the bin (where it hides the cubes under it from the overhead camera, so that the next
// approach puts a finger on one). Trial 43 of seed 1 pushes in its first 20 s; with the tree that
// looked straight after the push, its next approach ended in a protective stop at 10.8 s.
TEST(Campaign, ClearingInCameraModeLooksAfterAPushWithTheHandOutOfTheView) {
  TempDir d;
  const RunResult r = runMinimanip("run experiments/bin_clearing.yaml --only 43 --set perception.mode=camera --set bt.time_budget=20 "
                                   "--set progress=none --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const json t = readTrials(d.path() / "out").at(0);
  ASSERT_GE(t["pushes"].get<int>(), 1) << "no push in the first 20 s: the test no longer tests it";
  for (const auto& f : t["failures"]) EXPECT_NE(f["kind"], "contact_force") << f.dump();
  EXPECT_EQ(t["objects_placed"], 2) << t.dump();
}

// A cube grasped with a yaw offset (the pads at an angle to its faces: every face-aligned candidate
// was tried first, so a pick that tried more than the four aligned ones took an offset one) turns
// square on the pads; the place expects it and sets it down within 2 degrees of the target. Trial 1
// of seed 1 has four such picks (they were placed 8.5 degrees off before).
TEST(Campaign, YawOffsetGraspsPlaceTheObjectSquare) {
  TempDir d;
  const RunResult r = runMinimanip("run experiments/bin_clearing.yaml --trials 2 --only 1 --set progress=none --out " +
                                   (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const json t = readTrials(d.path() / "out").at(0);
  int offset = 0;
  for (const auto& p : t["picks"]) {
    if (!p["at_target"].get<bool>()) continue;
    offset += p["grasp_candidates_tried"].get<int>() > 4;
    EXPECT_LT(p["orientation_error"].get<double>(), 2 * M_PI / 180) << p.dump();
  }
  EXPECT_GE(offset, 1) << "no yaw-offset grasp in the trial: the test no longer tests it";
}

TEST(Campaign, WeldModeSucceeds) {
  TempDir d;
  const RunResult r = runMinimanip("run experiments/quickstart.yaml --trials 2 --set grasp.mode=weld --set progress=none --out " +
                                   (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const auto& t : readTrials(d.path() / "out")) EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
}

// The same experiment and seed give identical outcome fields, run again or with one, two or three
// worker processes.
TEST(Campaign, DeterministicAcrossRunsAndWorkerCounts) {
  TempDir d;
  const std::string base = "run experiments/quickstart.yaml --trials 6 --seed 77 --set objects.count_max=3 --set progress=none";
  ASSERT_EQ(runMinimanip(base + " --jobs 1 --out " + (d.path() / "a").string()).code, 0);
  ASSERT_EQ(runMinimanip(base + " --jobs 1 --out " + (d.path() / "b").string()).code, 0);
  ASSERT_EQ(runMinimanip(base + " --jobs 2 --out " + (d.path() / "c").string()).code, 0);
  ASSERT_EQ(runMinimanip(base + " --jobs 3 --out " + (d.path() / "c3").string()).code, 0);
  const auto a = readTrials(d.path() / "a"), b = readTrials(d.path() / "b"), c = readTrials(d.path() / "c"),
             c3 = readTrials(d.path() / "c3");
  ASSERT_EQ(a.size(), 6u);
  ASSERT_EQ(b.size(), 6u);
  ASSERT_EQ(c.size(), 6u);
  ASSERT_EQ(c3.size(), 6u);
  std::set<int> counts;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(outcomeFields(a[i]), outcomeFields(b[i])) << "trial " << i;
    EXPECT_EQ(outcomeFields(a[i]), outcomeFields(c[i])) << "trial " << i << " with 2 workers";
    EXPECT_EQ(outcomeFields(a[i]), outcomeFields(c3[i])) << "trial " << i << " with 3 workers";
    counts.insert(a[i]["objects_in_bin"].get<int>());
  }
  EXPECT_GT(counts.size(), 1u) << "the seeded sampler should vary the number of objects";
  // One trial again, alone, in reverse order with another: the same as in the full campaign.
  ASSERT_EQ(runMinimanip(base + " --only 4,1 --out " + (d.path() / "o").string()).code, 0);
  const auto o = readTrials(d.path() / "o");
  ASSERT_EQ(o.size(), 2u);
  EXPECT_EQ(outcomeFields(o[0]), outcomeFields(a[1]));
  EXPECT_EQ(outcomeFields(o[1]), outcomeFields(a[4]));
  // A different seed changes the scenes.
  ASSERT_EQ(runMinimanip("run experiments/quickstart.yaml --trials 6 --seed 78 --set progress=none --out " +
                         (d.path() / "e").string()).code, 0);
  EXPECT_NE(outcomeFields(readTrials(d.path() / "e")[0])["sim_time"], outcomeFields(a[0])["sim_time"]);
}

// ---- bad input: exit code 2, a message naming the file and the place, no results written ----

class BadInput : public ::testing::Test {
 protected:
  void expectRejected(const std::string& args, const std::string& regex) {
    const fs::path out = dir_.path() / "results_out";
    const RunResult r = runMinimanip(args + " --out " + out.string());
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_THAT(r.out, MatchesRegex("(.|\n)*" + regex + "(.|\n)*"));
    EXPECT_FALSE(fs::exists(out)) << "a rejected run must not leave a results directory";
  }
  std::string experiment(const std::string& body) {
    return dir_.file("exp.yaml", "robot: " + source("robots/panda/panda.yaml") + "\nscene: " +
                                     source("scenes/bin_table.xml") + "\n" + body);
  }
  TempDir dir_;
};

TEST_F(BadInput, MissingExperimentFile) {
  expectRejected("run no/such/file.yaml", "no/such/file\\.yaml: cannot open file");
}

TEST_F(BadInput, MalformedYaml) {
  const std::string f = experiment("trials: [1, 2\nseed: 3\n");
  expectRejected("run " + f, "exp\\.yaml:[0-9]+:[0-9]+: malformed YAML");
}

TEST_F(BadInput, UnknownKeyNamesLineAndSection) {
  const std::string f = experiment("grasp:\n  forse: 30\n");
  expectRejected("run " + f, "exp\\.yaml:4:3: unknown key 'grasp\\.forse' \\(known in this section: grasp\\.mode");
}

TEST_F(BadInput, ValueOutOfRange) {
  const std::string f = experiment("trials: 0\n");
  expectRejected("run " + f, "exp\\.yaml:3:[0-9]+: 'trials' must be in \\[1, 1e\\+07\\], got 0");
}

TEST_F(BadInput, WrongTypeAndBadChoice) {
  expectRejected("run " + experiment("seed: abc\n"), "'seed' expects an integer, got 'abc'");
  expectRejected("run " + experiment("hardware: gazebo\n"), "'hardware' expects one of mujoco, mock, got 'gazebo'");
}

TEST_F(BadInput, SetOverridesAreValidatedToo) {
  expectRejected("run experiments/quickstart.yaml --set grasp.force=5000", "--set grasp\\.force: 'grasp\\.force' must be in \\[1, 1000\\]");
  // Within the option's range but past the mounted gripper's limit.
  expectRejected("run experiments/quickstart.yaml --set grasp.force=500",
                 "grasp\\.force 500 N is past the gripper's limit \\(70 N, .*robots/grippers/panda_hand\\.yaml\\)");
  expectRejected("run experiments/quickstart.yaml --set nokey=1", "--set nokey: unknown key 'nokey'");
}

TEST_F(BadInput, InconsistentCounts) {
  expectRejected("run " + experiment("objects:\n  count_min: 4\n  count_max: 2\n"), "count_min \\(4\\) must be <= objects\\.count_max \\(2\\)");
}

TEST_F(BadInput, OnlyListsTrialIndices) {
  expectRejected("run " + experiment("trials: 10\n") + " --only 3,10", "'only' lists trial 10, expected indices below trials \\(10\\)");
  expectRejected("run " + experiment("") + " --only 1.5", "'only' expects a list of integers, got '1\\.5'");
}

TEST_F(BadInput, MalformedMjcfXml) {
  std::ifstream in("scenes/bin_table.xml");
  std::stringstream s;
  s << in.rdbuf();
  std::string xml = s.str();
  xml.replace(xml.find("<geom name=\"table\""), 5, "<geom name=\"table\"<");
  fs::create_directories(dir_.path() / "sub");
  dir_.file("sub/scene.xml", xml);
  const std::string f2 = dir_.file("exp2.yaml", "robot: " + source("robots/panda/panda.yaml") + "\nscene: sub/scene.xml\n");
  expectRejected("run " + f2, "sub/scene\\.xml:[0-9]+: malformed XML");
}

TEST_F(BadInput, NanSizeAndZeroQuaternionInMjcf) {
  std::ifstream in("scenes/bin_table.xml");
  std::stringstream s;
  s << in.rdbuf();
  const std::string xml = s.str();
  fs::create_directories(dir_.path() / "sub");
  std::string nan = xml;
  nan.replace(nan.find("size=\"0.6 0.75 0.375\""), 21, "size=\"0.6 nan 0.375\"");
  dir_.file("sub/scene.xml", nan);
  const std::string f = dir_.file("exp.yaml", "robot: " + source("robots/panda/panda.yaml") + "\nscene: sub/scene.xml\n");
  expectRejected("run " + f, "sub/scene\\.xml:[0-9]+: <geom> size=\"0\\.6 nan 0\\.375\": expected finite numbers");
  std::string zq = xml;
  zq.replace(zq.find("<geom name=\"table\""), 18, "<geom name=\"table\" quat=\"0 0 0 0\"");
  dir_.file("sub/scene.xml", zq);
  expectRejected("run " + f, "sub/scene\\.xml:[0-9]+: <geom> quat is zero");
}

TEST_F(BadInput, GripperWithOneFinger) {
  const std::string g = dir_.file("one_finger.yaml", R"(name: g
travel: 0.04
max_force: 50
velocity: 0.1
finger_z: 0.05
pad_friction: 1
tcp: {name: g_tcp, offset: 0.1}
hand: {name: g_hand, mass: 0.5, shapes: [{type: sphere, pos: [0, 0, 0.03], radius: 0.03}]}
fingers:
  - {name: g_left, joint: g_left_joint, mass: 0.02, shapes: [{type: box, pos: [0, 0.01, 0.02], half: [0.01, 0.01, 0.02]}]}
)");
  expectRejected("run " + experiment("gripper: one_finger.yaml\n"), "one_finger\\.yaml:[0-9]+:[0-9]+: 'fingers' expects two fingers");
}

TEST_F(BadInput, SceneHoldingTheRobot) {
  // A scene of the old kind, with the robot in it: the harness mounts the robot itself.
  std::stringstream s;
  s << std::ifstream("scenes/bin_table.xml").rdbuf();
  std::string xml = s.str();
  xml.replace(xml.find("<default>"), 9, "<include file=\"" + source("robots/panda/panda.xml") + "\"/>\n  <default>");
  dir_.file("scene.xml", xml);
  const std::string f = dir_.file("exp.yaml", "robot: " + source("robots/panda/panda.yaml") + "\nscene: scene.xml\n");
  expectRejected("run " + f, "panda\\.xml:[0-9]+: body 'panda_link0' belongs to the robot");
}

TEST_F(BadInput, UnknownOptionAndCommand) {
  expectRejected("run experiments/quickstart.yaml --frobnicate", "argument was not expected: --frobnicate");
  const RunResult r = runMinimanip("fly");
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.out, HasSubstr("fly: unknown command"));
}

// ---- behavior trees that cannot be loaded: exit 2 before any trial, naming file and line ----

struct BadTree {
  const char* file;
  const char* message;  // regex after "<file>:<line>: "
};

class BadTrees : public ::testing::TestWithParam<BadTree> {};

TEST_P(BadTrees, ExitTwoNamingFileLineAndNode) {
  TempDir d;
  const fs::path out = d.path() / "out";
  const std::string file = std::string("tests/bt/bad_trees/") + GetParam().file;
  const RunResult r = runMinimanip("run experiments/quickstart.yaml --set tree=" + file + " --out " + out.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, MatchesRegex("(.|\n)*" + file + ":[0-9]+: " + GetParam().message + "(.|\n)*"));
  EXPECT_FALSE(fs::exists(out)) << "a rejected run must not leave a results directory";
}

INSTANTIATE_TEST_SUITE_P(
    Corpus, BadTrees,
    ::testing::Values(BadTree{"unknown_node.xml", "<PlanAndExecuteGrasp>: Node not recognized"},
                      BadTree{"bad_port.xml", "<PlanAndExecutePick>: a port with name \\[object\\] is found in the XML"},
                      BadTree{"missing_port.xml", "<PlanAndExecutePick>: missing required port \\[object_pose\\]"},
                      BadTree{"wrong_type.xml", "<IsLessThan>: The port with name \"key_B\" and value \"three\" can not be converted to int"},
                      BadTree{"port_type_clash.xml", "<IncrementCounter>: The creation of the tree failed because the port \\[p\\]"},
                      BadTree{"bad_script.xml", "<Script>: Expected operand at position 16"},
                      BadTree{"unclosed_tag.xml", "malformed XML: XML_ERROR_MISMATCHED_ELEMENT"},
                      BadTree{"missing_subtree.xml", "<SubTree>: Can't find a tree with name: ExecuteGrasp"},
                      BadTree{"recursive_subtree.xml", "<SubTree>: Recursive behavior tree cycle detected"},
                      BadTree{"missing_include.xml", "no such behavior-tree file"}),
    [](const ::testing::TestParamInfo<BadTree>& i) {
      std::string n = i.param.file;
      return n.substr(0, n.size() - 4);
    });

}  // namespace
}  // namespace mm
