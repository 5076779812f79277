// Trees over the node library, run as the campaign runs them (TrialRunner: 10 Hz ticks on
// simulated time, the executor stepping the hardware, the result evaluated in the simulator): the
// source's two trees from experiments/trees/ on mock hardware and on MuJoCo, and trees of our own,
// one of which halts the arm mid-motion and checks that the stop stays within the unscaled limits.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <functional>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "bt/manip_nodes.h"
#include "campaign/trial.h"
#include "sim/hardware.h"
#include "sim/scene_sampler.h"
#include "sim/sim_world.h"
#include "task/pick_place.h"
#include "../sanitized.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

// Forwards to a backend and records every setpoint written to it.
class RecordingHardware final : public ForwardingHardware {
 public:
  using ForwardingHardware::ForwardingHardware;
  struct Setpoint {
    VecX q, qd, qdd;
  };
  std::vector<Setpoint> written;
  void write(const VecX& q, const VecX& qd, const VecX& qdd) override {
    written.push_back({q, qd, qdd});
    in_.write(q, qd, qdd);
  }
};

struct Result {
  TrialOutcome out;
  std::vector<RecordingHardware::Setpoint> written;
  double dt = 0.002;
};

// One trial of the quickstart cell with `tree` (a file under experiments/trees/ or inline XML).
// `moved`, when given: how far each object in play moved on the table (xy) during the trial.
/// `arrange` may move the spawned objects (their pool indices) before the trial starts.
Result runTree(const std::string& tree, std::vector<std::string> sets, uint64_t trial, std::vector<double>* moved = nullptr,
               const std::function<void(SimWorld&, const std::vector<int>&)>& arrange = {}) {
  const bool file = tree.find('<') == std::string::npos;
  if (file) sets.push_back("tree=experiments/trees/" + tree);
  const Experiment e = loadExperiment("experiments/quickstart.yaml", sets);
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);
  bt::Factory f;
  bt::TaskNodeEnv env;
  bt::registerTaskNodes(f, env);
  const bt::TreeDocument doc = file ? f.load(e.tree_path) : f.loadText(tree, "inline.xml");
  const fs::path logs = fs::temp_directory_path() / ("mm_trees_" + std::to_string(::getpid()));
  fs::create_directories(logs);
  TrialRunner runner(e, cell, doc, logs.string(), "2026-01-01 00:00:00");
  Rng rng = Rng::stream(e.seed, trial, Purpose::kScene);
  const SpawnResult spawn = spawnObjects(*world, robot, cell.T_world_bin, cell.bin_half, rng, cell.spawn);
  EXPECT_TRUE(spawn.ok) << spawn.reason;
  if (arrange) arrange(*world, spawn.active);
  auto backend = e.hardware == "mock" ? makeMockHardware(*world, robot, spawn.active)
                                      : makeMujocoHardware(*world, robot, spawn.active);
  RecordingHardware hw(*backend);
  std::vector<Vec3> start;
  for (int i : spawn.active) start.push_back(world->object(i).T_world_object.translation());
  Result r;
  std::string log;
  r.out = runner.run(hw, *world, trial, log);
  if (moved) {
    moved->clear();
    for (size_t k = 0; k < spawn.active.size(); ++k)
      moved->push_back((world->object(spawn.active[k]).T_world_object.translation() - start[k]).head<2>().norm());
  }
  r.written = std::move(hw.written);
  r.dt = hw.period();
  fs::remove_all(logs);
  return r;
}

// The same trial through the tree-less chain (runPickAndPlace): the reference pick_place.xml is
// held to.
TrialOutcome runChain(uint64_t trial) {
  const Experiment e = loadExperiment("experiments/quickstart.yaml", {});
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  auto world = loadWorld(e, robot);
  const Cell cell = makeCell(e, robot, *world);
  Rng rng = Rng::stream(e.seed, trial, Purpose::kScene);
  const SpawnResult spawn = spawnObjects(*world, robot, cell.T_world_bin, cell.bin_half, rng, cell.spawn);
  EXPECT_TRUE(spawn.ok) << spawn.reason;
  auto hw = makeMujocoHardware(*world, robot, spawn.active);
  TrialContext ctx(*hw, robot, cell.statics, e.task, cell.perception, e.seed, trial);
  ctx.target_half_height = cell.place_target_half_height;
  runPickAndPlace(ctx, cell.T_world_place_target);
  return std::move(ctx.out);
}

std::string describe(const TrialOutcome& o) {
  std::string s = (o.success ? "success" : "FAILED at " + o.failure_stage + ": " + o.failure_reason) + "; tree " +
                  o.tree_status + "; placed " + std::to_string(o.picks.size()) + ", left " + std::to_string(o.objects_left_in_bin);
  for (const auto& f : o.failures) s += "\n  failure: " + f.failure.stage + " (" + failureKindName(f.failure.kind) + ") " + f.failure.reason;
  return s;
}

int placed(const TrialOutcome& o) {
  return static_cast<int>(std::count_if(o.picks.begin(), o.picks.end(), [](const PickRecord& p) { return p.placed; }));
}

const std::vector<std::string> kMock = {"hardware=mock"};
std::vector<std::string> withCubes(std::vector<std::string> sets, int n) {
  sets.push_back("objects.count_min=" + std::to_string(n));
  sets.push_back("objects.count_max=" + std::to_string(n));
  return sets;
}

// ---- the source's trees ----------------------------------------------------------------------

TEST(SourceTrees, MiniManipPicksAndPlacesOnMockAndMujoco) {
  for (const auto& sets : {kMock, std::vector<std::string>{}}) {
    for (uint64_t trial : {0u, 1u}) {
      const Result r = runTree("mini_manip.xml", sets, trial);
      EXPECT_TRUE(r.out.success) << describe(r.out);
      EXPECT_EQ(r.out.tree, "MiniManip");
      EXPECT_EQ(placed(r.out), 1);
      EXPECT_EQ(r.out.collision_count, 0);
    }
  }
}

TEST(SourceTrees, BinPickingAsWrittenPicksOnceAndCutsTheLastCubesIterationOnMockAndMujoco) {
  for (const auto& sets : {kMock, std::vector<std::string>{}}) {
    SCOPED_TRACE(sets.empty() ? "MuJoCo" : "mock");
    // Two cubes: WhileDoElse is not a loop; one pick-place and the tree is done (no home, no report).
    const Result two = runTree("bin_picking.xml", withCubes(sets, 2), 0);
    EXPECT_TRUE(two.out.success) << describe(two.out);
    EXPECT_EQ(placed(two.out), 1);
    EXPECT_EQ(two.out.objects_left_in_bin, 1);
    EXPECT_EQ(two.out.reported_total, -1);
    // One cube: the condition is ticked on every tick. IsBinNotEmpty counts the cube in the hand,
    // so the pick and the place go on; once the fingers let go of it the condition fails and the
    // rest of the iteration is halted: no retreat (MoveToSafe), no IncrementCounter; the else
    // branch goes home and reports 0 objects with the one cube placed.
    const Result one = runTree("bin_picking.xml", withCubes(sets, 1), 0);
    EXPECT_TRUE(one.out.success) << describe(one.out);
    EXPECT_EQ(placed(one.out), 1);
    EXPECT_EQ(one.out.objects_left_in_bin, 0);
    EXPECT_EQ(one.out.reported_total, 0);
    EXPECT_EQ(one.out.collision_count, 0);
    const auto stage = [&](const std::string& name) {
      return std::any_of(one.out.stages.begin(), one.out.stages.end(), [&](const StageRecord& s) { return s.name == name; });
    };
    EXPECT_FALSE(stage("plan_safe"));
    EXPECT_TRUE(stage("return_home"));
    // With the bin's sensor alone (count_held="false"), lifting the one cube empties the bin: the
    // pick is halted with the cube in the hand and the trial fails.
    std::ifstream in("experiments/trees/bin_picking.xml");
    std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string plain = "<IsBinNotEmpty/>";
    ASSERT_NE(xml.find(plain), std::string::npos);
    xml.replace(xml.find(plain), plain.size(), R"(<IsBinNotEmpty count_held="false"/>)");
    const Result sensor = runTree(xml, withCubes(sets, 1), 0);
    EXPECT_FALSE(sensor.out.success) << describe(sensor.out);
    EXPECT_THAT(sensor.out.failures, ::testing::Contains(::testing::Field(
                                        &RecordedFailure::failure, ::testing::Field(&Failure::kind, FailureKind::kHalted))));
    EXPECT_EQ(placed(sensor.out), 0);
  }
}

TEST(SourceTrees, PickPlaceTreeGivesTheChainsOutcomesOnTheQuickstart) {
  // Deliverable of the task layer as actions: pick_place.xml and the tree-less chain of the same
  // actions give the same outcome fields, trial by trial (100 quickstart trials of seed 1; the first
  // 25 under the sanitizers).
  const uint64_t trials = testing_sanitized::sanitizedOr(25, 100);
  for (uint64_t trial = 0; trial < trials; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const TrialOutcome tree = runTree("pick_place.xml", {}, trial).out;
    const TrialOutcome chain = runChain(trial);
    ASSERT_EQ(tree.success, chain.success) << describe(tree) << "\n" << describe(chain);
    EXPECT_EQ(tree.failure_stage, chain.failure_stage);
    EXPECT_EQ(tree.target_object, chain.target_object);
    EXPECT_EQ(tree.collision_count, chain.collision_count);
    EXPECT_EQ(tree.place_position_error, chain.place_position_error);
    EXPECT_EQ(tree.place_orientation_error, chain.place_orientation_error);
    EXPECT_EQ(tree.sim_time, chain.sim_time);
    EXPECT_EQ(tree.execute_pick_time, chain.execute_pick_time);
    EXPECT_EQ(tree.execute_place_time, chain.execute_place_time);
    ASSERT_EQ(tree.stages.size(), chain.stages.size());
    for (size_t k = 0; k < tree.stages.size(); ++k) {
      EXPECT_EQ(tree.stages[k].name, chain.stages[k].name);
      EXPECT_EQ(tree.stages[k].ok, chain.stages[k].ok);
      EXPECT_EQ(tree.stages[k].sim_seconds, chain.stages[k].sim_seconds);
    }
  }
}

TEST(SourceTrees, BinPickingCorrectedClearsTheBinOnMockAndMujoco) {
  for (const auto& sets : {kMock, std::vector<std::string>{}}) {
    const Result r = runTree("bin_picking_fixed.xml", withCubes(sets, 3), 2);
    EXPECT_TRUE(r.out.success) << describe(r.out);
    EXPECT_EQ(placed(r.out), 3);
    EXPECT_EQ(r.out.objects_left_in_bin, 0);
    EXPECT_EQ(r.out.reported_total, 3);
    EXPECT_EQ(r.out.collision_count, 0);
  }
}

// ---- trees of our own ------------------------------------------------------------------------

std::string wrap(const std::string& body) {
  return "<root BTCPP_format=\"4\"><BehaviorTree ID=\"T\">" + body + "</BehaviorTree></root>";
}

TEST(OwnTrees, TimeoutHaltsThePickMidMotionWithinTheUnscaledLimits) {
  // At full speed, the move to the pre-grasp is under way when the Timeout fires at 0.6 s.
  const Result r = runTree(wrap(R"(
      <Sequence>
        <DetectObject object_pose="{p}"/>
        <Timeout msec="600"><PlanAndExecutePick object_pose="{p}"/></Timeout>
      </Sequence>)"),
                           {"motion.velocity_scaling=1.0", "motion.acceleration_scaling=1.0"}, 0);
  EXPECT_FALSE(r.out.success);
  EXPECT_THAT(r.out.failures, ::testing::Contains(::testing::Field(
                                 &RecordedFailure::failure, ::testing::Field(&Failure::kind, FailureKind::kHalted))));
  static const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  ASSERT_GT(r.written.size(), 300u);
  // Every setpoint streamed, the stop included: within the unscaled velocity, acceleration and
  // jerk limits, and no jump in position.
  double peak_speed = 0, last_speed = 1;
  for (size_t k = 1; k < r.written.size(); ++k) {
    const auto& a = r.written[k - 1];
    const auto& b = r.written[k];
    for (int j = 0; j < robot.dof(); ++j) {
      ASSERT_LE(std::abs(b.qd[j]), robot.vmax()[j] * (1 + 1e-6)) << "joint " << j << " sample " << k;
      ASSERT_LE(std::abs(b.qdd[j]), robot.amax()[j] * (1 + 1e-6)) << "joint " << j << " sample " << k;
      ASSERT_LE(std::abs(b.qdd[j] - a.qdd[j]) / r.dt, robot.jmax()[j] * (1 + 1e-6)) << "joint " << j << " sample " << k;
      ASSERT_LE(std::abs(b.q[j] - a.q[j]), robot.vmax()[j] * r.dt * (1 + 1e-6)) << "joint " << j << " sample " << k;
    }
    peak_speed = std::max(peak_speed, b.qd.cwiseAbs().maxCoeff());
    last_speed = b.qd.cwiseAbs().maxCoeff();
  }
  EXPECT_GT(peak_speed, 0.5) << "the arm was moving fast when halted";
  EXPECT_LT(last_speed, 1e-9) << "it ends at rest";
  EXPECT_LT(r.out.sim_time, 1.6) << "it stopped instead of finishing the pick";
}

TEST(OwnTrees, FallbackRecoversFromAPickAtTheWrongPlace) {
  const Result r = runTree(wrap(R"(
      <Sequence>
        <SetBlackboard output_key="wrong" value="0.9;0.9;0.1"/>
        <Fallback>
          <PlanAndExecutePick object_pose="{wrong}"/>
          <Sequence>
            <DetectObject object_pose="{p}"/>
            <PlanAndExecutePick object_pose="{p}"/>
          </Sequence>
        </Fallback>
        <PlanAndExecutePlace place_pose="{place_target}"/>
        <MoveToHome/>
      </Sequence>)"),
                           kMock, 0);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  EXPECT_TRUE(r.out.recovery_needed);
  EXPECT_TRUE(r.out.recovery_success);
  EXPECT_EQ(r.out.recovery_attempts, 1);
  ASSERT_EQ(r.out.failures.size(), 1u);
  EXPECT_EQ(r.out.failures[0].failure.kind, FailureKind::kPrecondition);
}

TEST(OwnTrees, AForeverRepeatEndsAsTimeoutAtTheBudget) {
  const Result r = runTree(wrap(R"(<Repeat num_cycles="-1"><AlwaysSuccess/></Repeat>)"), {"hardware=mock", "bt.time_budget=2"}, 0);
  EXPECT_FALSE(r.out.success);
  EXPECT_EQ(r.out.tree_status, "TIMEOUT");
  EXPECT_EQ(r.out.failure_kind, FailureKind::kTimeout);
  EXPECT_NEAR(r.out.sim_time, 2.0, 0.01);
}

// MuJoCo resets its state where it flags a bad one (a NaN here, an object's position): the trial
// ends at the first SIM_UNSTABLE failure, which stays its failure, though the tree has attempts
// left (the recovering tree's four).
TEST(OwnTrees, ASimulatorInstabilityEndsTheTrialWithItsFailure) {
  const Result r = runTree("recovering_pick_place.xml", withCubes({}, 2), 0, nullptr, [](SimWorld& w, const std::vector<int>& active) {
    Pose T = w.object(active[1]).T_world_object;
    T.translation().z() = std::nan("");
    w.setObjectPose(active[1], T);
  });
  EXPECT_FALSE(r.out.success);
  EXPECT_TRUE(r.out.sim_unstable);
  EXPECT_EQ(r.out.failure_kind, FailureKind::kSimUnstable) << describe(r.out);
  long unstable = 0;
  for (const auto& f : r.out.failures) unstable += f.failure.kind == FailureKind::kSimUnstable;
  EXPECT_EQ(unstable, 1) << describe(r.out);
}

TEST(OwnTrees, SleepCountsSimulatedTime) {
  const std::string pick_place = R"(<DetectObject object_pose="{p}"/><PlanAndExecutePick object_pose="{p}"/>
        <PlanAndExecutePlace place_pose="{place_target}"/><MoveToHome/>)";
  const Result plain = runTree(wrap("<Sequence>" + pick_place + "</Sequence>"), kMock, 0);
  const Result slept = runTree(wrap("<Sequence><Sleep msec=\"500\"/>" + pick_place + "</Sequence>"), kMock, 0);
  ASSERT_TRUE(plain.out.success && slept.out.success);
  // Within a control period: the holds that end on "time - start < duration" may take one more or
  // one fewer period at a different start time (floating-point time).
  EXPECT_NEAR(slept.out.sim_time - plain.out.sim_time, 0.5, 0.0021);
  EXPECT_EQ(slept.out.place_position_error, plain.out.place_position_error);
}

TEST(OwnTrees, TheMtcStagesOneByOne) {
  const Result r = runTree(wrap(R"(
      <Sequence>
        <TriggerPointCloud/>
        <WaitForGraspCandidates candidates="{list}"/>
        <SelectBestGrasp candidates="{list}" selected="{g}"/>
        <OpenGripper/>
        <PlanMTCPick grasp_pose="{g}" approach_dist="0.12"/>
        <ExecuteMTCPlan/>
        <VerifyGraspForce min_force="10" result="{ok}"/>
        <ScriptCondition code="ok"/>
        <ComputePlacePosition pick_count="0" place_pose="{slot}"/>
        <PlanMTCPlace place_pose="{slot}"/>
        <ExecuteMTCPlan/>
        <OpenGripper/>
        <MoveToSafe/>
        <MoveToHome/>
      </Sequence>)"),
                           {}, 1);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  EXPECT_EQ(placed(r.out), 1);
  EXPECT_LT(r.out.place_position_error, 0.01);
}

TEST(OwnTrees, AReactiveHealthMonitorAboveThePick) {
  const Result r = runTree(wrap(R"(
      <ReactiveSequence>
        <IsSystemHealthy max_tracking_error="0.02"/>
        <Sequence>
          <DetectObject object_pose="{p}"/>
          <PlanAndExecutePick object_pose="{p}"/>
          <PlanAndExecutePlace place_pose="{place_target}"/>
          <MoveToHome/>
        </Sequence>
      </ReactiveSequence>)"),
                           {}, 0);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  // Ticked at 10 Hz while the arm moved (the trial's last 0.5 s is the evaluation's settle).
  EXPECT_GT(r.out.ticks, 0.8 * (r.out.sim_time - 0.5) / 0.1) << "ticked at 10 Hz while the arm moved";
  EXPECT_GT(r.out.ticks, 30);
}

TEST(OwnTrees, ClosingOnNothingFailsTheGraspCheck) {
  const Result r = runTree(wrap(R"(
      <Sequence>
        <CloseGripper/>
        <VerifyGraspForce result="{ok}"/>
        <Precondition if="ok" else="FAILURE"><AlwaysSuccess/></Precondition>
      </Sequence>)"),
                           kMock, 0);
  EXPECT_FALSE(r.out.success);
  EXPECT_EQ(r.out.tree_status, "FAILURE");
  EXPECT_EQ(r.out.failure_kind, FailureKind::kTree);
}

TEST(OwnTrees, TwoArmActionsInAParallelMoveOneAfterTheOther) {
  // The second waits, RUNNING, while the first moves the arm, and plans from where it rests.
  const Result r = runTree(wrap(R"(
      <Sequence>
        <DetectObject object_pose="{p}"/>
        <Parallel success_count="2" failure_count="1">
          <PlanAndExecutePick object_pose="{p}"/>
          <MoveToHome/>
        </Parallel>
        <PlanAndExecutePlace place_pose="{place_target}"/>
      </Sequence>)"),
                           kMock, 0);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  std::vector<std::string> names;
  for (const StageRecord& st : r.out.stages) names.push_back(st.name);
  const auto at = [&](const std::string& n) { return std::find(names.begin(), names.end(), n) - names.begin(); };
  EXPECT_LT(at("lift"), at("plan_home"));
  EXPECT_LT(at("return_home"), at("connect_place"));
}

TEST(OwnTrees, ARepeatFillsTheSlotsOfThePlaceGrid) {
  const Result r = runTree(wrap(R"(
      <Sequence>
        <SetBlackboard output_key="n" value="0"/>
        <Repeat num_cycles="2">
          <Sequence>
            <DetectObject object_pose="{p}"/>
            <PlanAndExecutePick object_pose="{p}"/>
            <ComputePlacePosition pick_count="{n}" place_pose="{slot}"/>
            <PlanAndExecutePlace place_pose="{slot}"/>
            <IncrementCounter key="{n}"/>
          </Sequence>
        </Repeat>
        <MoveToHome/>
        <ReportCompletion total="{n}"/>
      </Sequence>)"),
                           withCubes(kMock, 2), 3);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  ASSERT_EQ(placed(r.out), 2);
  EXPECT_EQ(r.out.reported_total, 2);
  EXPECT_NEAR((r.out.picks[0].T_world_target.translation() - r.out.picks[1].T_world_target.translation()).norm(), 0.06, 1e-9);
}

TEST(OwnTrees, NextFreeFillsTheSlotsWithNoCounter) {
  const Result r = runTree(wrap(R"(
      <Sequence>
        <Repeat num_cycles="2">
          <Sequence>
            <DetectObject object_pose="{p}"/>
            <PlanAndExecutePick object_pose="{p}"/>
            <ComputePlacePosition next_free="true" place_pose="{slot}"/>
            <PlanAndExecutePlace place_pose="{slot}"/>
          </Sequence>
        </Repeat>
        <MoveToHome/>
      </Sequence>)"),
                           withCubes(kMock, 2), 3);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  ASSERT_EQ(placed(r.out), 2);
  EXPECT_NEAR((r.out.picks[0].T_world_target.translation() - r.out.picks[1].T_world_target.translation()).norm(), 0.06, 1e-9);
}

// A 5 mm plate held across its thickness stops each finger 2.5 mm open: held, not "nothing
// between the fingers" (the generated objects' hollow walls are 5 to 12 mm thick).
TEST(OwnTrees, AThinPlateHeldAcrossItsThicknessIsHeld) {
  const fs::path catalogue = fs::temp_directory_path() / ("mm_plate_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(catalogue) << "kinds:\n  plate:\n    shape: box\n    size: [0.04, 0.005, 0.05]\n    mass: 0.02\n";
  const auto upright_in_the_middle = [](SimWorld& w, const std::vector<int>& active) {
    const auto [T_bin, half] = w.site("bin_region");
    w.setObjectPose(active.at(0), makePose(T_bin.translation() + Vec3(0, 0, 0.025), Mat3::Identity()));
  };
  const Result r = runTree("pick_place.xml", {"hardware=mock", "objects.catalogue=" + catalogue.string(), "objects.kinds=plate",
                                              "objects.count_min=1", "objects.count_max=1"},
                           0, nullptr, upright_in_the_middle);
  fs::remove(catalogue);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  ASSERT_EQ(r.out.grasp_attempts.size(), 1u);
  EXPECT_EQ(r.out.grasp_attempts[0].result, "in_tray");
  EXPECT_LT(r.out.grasp_opening, 0.003) << "each finger";
  EXPECT_GT(r.out.grasp_opening, kEmptyGrip);
}

TEST(PlaceGrid, NextFreePassesFilledSlotsAndThoseAPlaceFailedAt) {
  TaskOptions o;
  o.place_rows = 1, o.place_columns = 3, o.place_pitch = 0.1;
  const std::vector<Vec3> offsets = placeGridOffsets(o);
  ASSERT_EQ(offsets.size(), 3u);
  EXPECT_NEAR(offsets[0].norm(), 0.0, 1e-12);  // the centre first
  std::vector<Vec3> slots;
  for (const Vec3& d : offsets) slots.push_back(Vec3(0.5, 0.2, 0.05) + d);
  const Vec3 near0 = slots[0] + Vec3(0.02, -0.03, 0.04);  // within half a pitch in the plane, whatever the height
  EXPECT_EQ(nextFreeSlot(slots, {}, {}, 0.1), 0);
  EXPECT_EQ(nextFreeSlot(slots, {near0}, {}, 0.1), 1);
  EXPECT_EQ(nextFreeSlot(slots, {near0}, {slots[1]}, 0.1), 2);
  // Every free slot failed at: the one failed at least; every slot filled: none.
  EXPECT_EQ(nextFreeSlot(slots, {near0}, {slots[1], slots[2], slots[1]}, 0.1), 2);
  EXPECT_EQ(nextFreeSlot(slots, {slots[0], slots[1], slots[2]}, {}, 0.1), -1);
}

TEST(OwnTrees, ASwitchAndASubtreeWithRemappedPorts) {
  const Result r = runTree(R"(<root BTCPP_format="4" main_tree_to_execute="Main">
      <BehaviorTree ID="Main">
        <Sequence>
          <Script code="mode := 'pick'"/>
          <Switch2 variable="{mode}" case_1="pick" case_2="home">
            <SubTree ID="PickPlace" target="{place_target}" _autoremap="false"/>
            <MoveToHome/>
            <AlwaysFailure/>
          </Switch2>
        </Sequence>
      </BehaviorTree>
      <BehaviorTree ID="PickPlace">
        <Sequence>
          <DetectObject object_pose="{cube}"/>
          <PlanAndExecutePick object_pose="{cube}"/>
          <PlanAndExecutePlace place_pose="{target}"/>
          <MoveToHome/>
        </Sequence>
      </BehaviorTree></root>)",
                           kMock, 1);
  EXPECT_TRUE(r.out.success) << describe(r.out);
}

TEST(OwnTrees, PreconditionsAndPostConditionsOnTaskNodes) {
  // _skipIf skips the first pick attempt; _onSuccess counts the successful place.
  const Result r = runTree(wrap(R"(
      <Sequence>
        <Script code="skip := true; places := 0"/>
        <DetectObject object_pose="{p}"/>
        <PlanAndExecutePick object_pose="{wrong}" _skipIf="skip"/>
        <PlanAndExecutePick object_pose="{p}"/>
        <PlanAndExecutePlace place_pose="{place_target}" _onSuccess="places += 1"/>
        <ScriptCondition code="places == 1"/>
        <MoveToHome/>
      </Sequence>)"),
                           kMock, 0);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  EXPECT_FALSE(r.out.recovery_needed);
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

TEST(OwnTrees, ATimeoutWhileTheArmMovesIsRecordedAsTimeoutNotAsTheHalt) {
  const Result r = runTree("pick_place.xml", {"bt.time_budget=1"}, 0);
  EXPECT_EQ(r.out.tree_status, "TIMEOUT");
  EXPECT_EQ(r.out.failure_kind, FailureKind::kTimeout) << describe(r.out);
  EXPECT_THAT(r.out.failures, ::testing::Contains(::testing::Field(
                                 &RecordedFailure::failure, ::testing::Field(&Failure::kind, FailureKind::kHalted))));
  EXPECT_FALSE(r.out.recovery_needed);
}

TEST(OwnTrees, PlanningAfterAHaltWaitsForTheArmToStopAndPlansFromThere) {
  // The first ExecuteMTCPlan is halted at 0.5 s (the arm brakes); the retry, in the same tick,
  // waits in PlanMTCPick for the arm to come to rest, plans from where it stopped (a plan from
  // the old start would be refused as a jump) and completes the pick without a timeout.
  const Result r = runTree(wrap(R"(
      <Sequence>
        <Script code="t := 500"/>
        <TriggerPointCloud/>
        <WaitForGraspCandidates candidates="{list}"/>
        <SelectBestGrasp candidates="{list}" selected="{g}"/>
        <RetryUntilSuccessful num_attempts="2">
          <Sequence>
            <PlanMTCPick grasp_pose="{g}"/>
            <Timeout msec="{t}" _onFailure="t := 0"><ExecuteMTCPlan/></Timeout>
          </Sequence>
        </RetryUntilSuccessful>
        <PlanAndExecutePlace place_pose="{place_target}"/>
        <MoveToHome/>
      </Sequence>)"),
                           {"motion.velocity_scaling=1.0", "motion.acceleration_scaling=1.0"}, 0);
  EXPECT_TRUE(r.out.success) << describe(r.out);
  EXPECT_THAT(r.out.failures, ::testing::Contains(::testing::Field(
                                 &RecordedFailure::failure, ::testing::Field(&Failure::kind, FailureKind::kHalted))));
}

// PushObject in the simulator: the closed fingers move a cube along a face normal by
// motion.push_distance (5 cm), without a collision, and the cube can be picked afterwards.
TEST(TaskTrees, PushObjectMovesACubeAndItIsPickedAfterwards) {
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="T"><BehaviorTree ID="T"><Sequence>
      <DetectObject object_pose="{p}"/>
      <PushObject object_pose="{p}"/>
      <MoveToHome/>
      <DetectObject object_pose="{p}"/>
      <IsGraspable object_pose="{p}"/>
      <PlanAndExecutePick object_pose="{p}"/>
    </Sequence></BehaviorTree></root>)";
  std::vector<double> moved;
  const Result r = runTree(xml, withCubes({}, 1), 0, &moved);
  EXPECT_EQ(r.out.pushes, 1);
  EXPECT_EQ(r.out.collision_count, 0) << ::testing::PrintToString(r.out.collision_log);
  EXPECT_EQ(r.out.tree_status, "SUCCESS") << describe(r.out);
  ASSERT_EQ(moved.size(), 1u);
  // Pushed 5 cm, then lifted with the pick (15 cm up, but xy stays): moved about 5 cm on the table.
  EXPECT_GT(moved[0], 0.03) << describe(r.out);
  EXPECT_LT(moved[0], 0.07) << describe(r.out);
  // The push is a contact task within its force limit, and its own cube is not a stray contact;
  // the contact force it took is recorded (a lone cube's friction: a few newtons).
  EXPECT_EQ(r.out.non_target_contacts, 0);
  EXPECT_GT(r.out.max_external_force, 0.3);
  EXPECT_LT(r.out.max_external_force, 100);
}

TEST(TaskTrees, ACubeFlushInACornerIsDraggedClearThenPicked) {
  // One cube flush in the bin's corner (bin_clearing.xml: inner walls at x 0.35..0.65, y -0.40..-0.10):
  // every grasp puts a finger against a wall and the closed fingers have no room beside it, so
  // PushObject drags it by its top away from the walls; then it is grasped.
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="T"><BehaviorTree ID="T"><Sequence>
      <DetectObject object_pose="{p}"/>
      <Inverter><IsGraspable object_pose="{p}"/></Inverter>
      <PushObject object_pose="{p}"/>
      <MoveToHome/>
      <DetectObject object_pose="{p}"/>
      <IsGraspable object_pose="{p}"/>
      <PlanAndExecutePick object_pose="{p}"/>
    </Sequence></BehaviorTree></root>)";
  std::vector<double> moved;
  const auto corner = [](SimWorld& w, const std::vector<int>& active) {
    w.setObjectPose(active.at(0), makePose(Vec3(0.65 - 0.0255, -0.10 - 0.0255, 0.035), Mat3::Identity()));
  };
  const Result r = runTree(xml, withCubes({"scene=scenes/bin_clearing.xml", "motion.drag_depth=0.002"}, 1), 0, &moved, corner);
  EXPECT_EQ(r.out.tree_status, "SUCCESS") << describe(r.out);
  EXPECT_EQ(r.out.pushes, 1);
  EXPECT_TRUE(std::any_of(r.out.stages.begin(), r.out.stages.end(), [](const StageRecord& s) { return s.name == "drag" && s.ok; }))
      << describe(r.out);
  EXPECT_EQ(r.out.collision_count, 0) << ::testing::PrintToString(r.out.collision_log);
  EXPECT_LT(r.out.max_external_force, 100);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_GT(moved[0], 0.03) << describe(r.out);
}

}  // namespace
}  // namespace mm
