// The simulated cell's fidelity and numerics (the fast, precise cell): a held cube stays put in the hand (within
// 0.5 mm) through a full-speed transport in friction mode, and creeps without the velocity-product
// term; a finer physics timestep is substepped under the same
// 500 Hz control and gives the same outcomes; a timestep that does not divide the control period
// is bad input.
#include <algorithm>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cli_helpers.h"

namespace mm {
namespace {

using ::testing::HasSubstr;
using namespace testing_cli;

const std::string kQuick = "run experiments/quickstart.yaml --trials 5 --seed 4 --jobs 2 --set progress=none --set bt.log=none";

TEST(Physics, AHeldCubeStaysInTheHandThroughAFullSpeedTransport) {
  // The quickstart runs at 100% of the joint velocity and acceleration limits, 0.5 m/s and
  // 3 m/s^2 on straight lines, friction grasping.
  TempDir d;
  const RunResult r = runMinimanip(kQuick + " --out " + (d.path() / "o").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = readTrials(d.path() / "o");
  ASSERT_EQ(trials.size(), 5u);
  for (const json& t : trials) {
    EXPECT_TRUE(t["success"].get<bool>()) << t.dump();
    EXPECT_EQ(t["collision_count"].get<int>(), 0);
    EXPECT_GT(t["in_hand_slip"].get<double>(), 0.0) << "measured, not a default";
    EXPECT_LT(t["in_hand_slip"].get<double>(), 0.0005) << "trial " << t["trial"];
    EXPECT_LT(t["place_position_error"].get<double>(), 0.001) << "trial " << t["trial"];
    EXPECT_LT(t["max_tracking_error"].get<double>(), 0.01);
  }
  // Without the velocity-product term in the contacts' reference accelerations (MuJoCo 2.2 as it
  // is) the swing makes the cube creep along the pads by more than a millimetre.
  const RunResult plain = runMinimanip(kQuick + " --set physics.velocity_product=false --out " + (d.path() / "p").string());
  ASSERT_EQ(plain.code, 0) << plain.out;
  double worst = 0;
  for (const json& t : readTrials(d.path() / "p")) worst = std::max(worst, t["in_hand_slip"].get<double>());
  EXPECT_GT(worst, 0.001);
}

TEST(Physics, AFinerTimestepIsSubsteppedUnderTheSameControlAndGivesTheSameOutcomes) {
  TempDir d;
  const RunResult coarse = runMinimanip(kQuick + " --out " + (d.path() / "a").string());
  const RunResult fine = runMinimanip(kQuick + " --set physics.timestep=0.0005 --out " + (d.path() / "b").string());
  ASSERT_EQ(coarse.code, 0) << coarse.out;
  ASSERT_EQ(fine.code, 0) << fine.out;
  const auto a = readTrials(d.path() / "a"), b = readTrials(d.path() / "b");
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i]["success"], b[i]["success"]);
    // The fidelity bound: place errors within 0.2 mm of the 0.5 ms reference.
    EXPECT_NEAR(a[i]["place_position_error"].get<double>(), b[i]["place_position_error"].get<double>(), 0.0002);
    // The same control period: stage durations are whole 2 ms periods either way.
    for (const json& s : b[i]["stages"]) {
      const double periods = s["sim_seconds"].get<double>() / 0.002;
      EXPECT_NEAR(periods, std::round(periods), 1e-6) << s.dump();
    }
  }
  const RunResult bad = runMinimanip(kQuick + " --set physics.timestep=0.0015 --out " + (d.path() / "c").string());
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_THAT(bad.out, HasSubstr("does not divide the control period"));
}

}  // namespace
}  // namespace mm
