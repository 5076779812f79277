// Fault injection: independent streams per kind, and every kind firing, detected and recovered
// from (or correctly given up) by the recovering tree in short seeded MuJoCo campaigns (camera
// kinds in camera mode), while the recovery-free tree fails on it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "campaign/campaign.h"
#include "campaign/experiment.h"
#include "campaign/record.h"
#include "core/error.h"
#include "faults/faults.h"
#include "robot/robot_model.h"
#include "sim/sim_world.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

TEST(FaultStreams, EachKindDrawsTheSameWhateverTheOtherRates) {
  const RobotModel robot = RobotModel::load("robots/panda/panda.yaml");
  auto world = SimWorld::load("scenes/bin_table.xml", robot);
  for (int k = 0; k < static_cast<int>(FaultKind::kCount); ++k) {
    const FaultKind kind = static_cast<FaultKind>(k);
    FaultOptions alone, crowded;
    alone.rate[k] = 0.3;
    crowded.rate.fill(0.7);
    crowded.rate[k] = 0.3;
    int strikes = 0;
    for (uint64_t trial = 0; trial < 300; ++trial) {
      const bool a = FaultInjector(alone, *world, 5, trial).drawn(kind);
      EXPECT_EQ(a, FaultInjector(crowded, *world, 5, trial).drawn(kind)) << faultKindName(kind) << " trial " << trial;
      strikes += a;
    }
    EXPECT_GT(strikes, 60) << faultKindName(kind);  // about 90 of 300 at 0.3
    EXPECT_LT(strikes, 120) << faultKindName(kind);
  }
}

TEST(FaultKinds, NamesRoundTripAndOnlyObjectRemovedIsUnrecoverable) {
  for (int k = 0; k < static_cast<int>(FaultKind::kCount); ++k) {
    const FaultKind kind = static_cast<FaultKind>(k);
    EXPECT_EQ(faultKindFromName(faultKindName(kind)), kind);
    EXPECT_EQ(faultRecoverable(kind), kind != FaultKind::kObjectRemoved) << faultKindName(kind);
  }
  EXPECT_EQ(faultKindFromName("gremlins"), FaultKind::kCount);
}

TEST(FaultKinds, CameraKindsNeedCameraMode) {
  for (const char* kind : {"camera_blackout", "depth_dropout", "extrinsics_drift"}) {
    try {
      loadExperiment("experiments/faults.yaml", {std::string("faults.") + kind + "=0.1"});
      ADD_FAILURE() << kind << " accepted with ground-truth perception";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("needs perception.mode camera"), std::string::npos) << e.what();
    }
    EXPECT_NO_THROW(loadExperiment("experiments/faults.yaml", {std::string("faults.") + kind + "=0.1", "perception.mode=camera"}));
  }
}

// experiments/faults.yaml with only `kind` injected, in every trial, by `tree`.
FaultStats campaignWithOnly(FaultKind kind, const std::string& tree, int trials, CampaignSummary* summary = nullptr) {
  std::vector<std::string> sets = {"trials=" + std::to_string(trials), "seed=3", "progress=none", "bt.log=none",
                                   "tree=" + tree};
  if (faultNeedsCamera(kind)) sets.push_back("perception.mode=camera");
  for (int k = 0; k < static_cast<int>(FaultKind::kCount); ++k)
    sets.push_back(std::string("faults.") + faultKindName(static_cast<FaultKind>(k)) + "=" +
                   (static_cast<FaultKind>(k) == kind ? "1" : "0"));
  const Experiment e = loadExperiment("experiments/faults.yaml", sets);
  const fs::path out = fs::temp_directory_path() / ("mm_faults_" + std::to_string(getpid()) + "_" + faultKindName(kind));
  runCampaign(e, {out.string(), "faults_test", MINIMANIP_BINARY});
  std::vector<TrialRecord> records;
  std::ifstream in(out / "trials.jsonl");
  for (std::string line; std::getline(in, line);) records.push_back(fromJsonLine(line, "trials.jsonl"));
  fs::remove_all(out);
  const CampaignSummary s = summarizeTrials(records);
  if (summary) *summary = s;
  for (const FaultStats& f : s.faults)
    if (f.kind == faultKindName(kind)) return f;
  return {};
}

class EveryFaultKind : public ::testing::TestWithParam<FaultKind> {};

TEST_P(EveryFaultKind, FiresIsDetectedAndRecoveredOrCorrectlyGivenUp) {
  CampaignSummary s;
  const FaultStats f = campaignWithOnly(GetParam(), "experiments/trees/recovering_pick_place.xml", 3, &s);
  EXPECT_GE(f.injected, 1);
  EXPECT_EQ(f.detected, f.injected) << "every injection must bite";
  if (faultRecoverable(GetParam())) {
    EXPECT_EQ(f.recovered, f.detected);
    EXPECT_EQ(f.given_up, 0) << "a recoverable kind is never given up";
    EXPECT_GT(f.mttr_mean, 0.0);
  } else {
    EXPECT_EQ(f.given_up, f.detected);
    EXPECT_EQ(f.recovered, 0) << "a given-up fault is not a recovery";
  }
  EXPECT_EQ(f.recovery, 1.0);
  EXPECT_EQ(s.collision_events, 0);
}

TEST_P(EveryFaultKind, TheRecoveryFreeTreeFailsOnIt) {
  if (!faultRecoverable(GetParam())) GTEST_SKIP() << "nothing to recover";
  const FaultStats f = campaignWithOnly(GetParam(), "experiments/trees/pick_place.xml", 2);
  EXPECT_GE(f.injected, 1);
  EXPECT_EQ(f.recovered, 0);
  EXPECT_EQ(f.unrecovered, f.injected);
}

std::vector<FaultKind> allKinds() {
  std::vector<FaultKind> v;
  for (int k = 0; k < static_cast<int>(FaultKind::kCount); ++k) v.push_back(static_cast<FaultKind>(k));
  return v;
}

INSTANTIATE_TEST_SUITE_P(Faults, EveryFaultKind, ::testing::ValuesIn(allKinds()),
                         [](const ::testing::TestParamInfo<FaultKind>& p) { return std::string(faultKindName(p.param)); });

}  // namespace
}  // namespace mm
