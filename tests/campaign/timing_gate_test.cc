// The side-by-side timing gate (tools/timing_gate): the candidate and the base run the same
// trials interleaved on this machine, so another campaign running beside them slows both alike. An
// unchanged build passes with such a campaign running; a planner made three times slower fails.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "cli_helpers.h"
#include "../sanitized.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using namespace testing_cli;

TEST(TimingGate, AnUnchangedBuildPassesBesideAnotherCampaignAndAThreeTimesSlowerPlannerFails) {
  if (testing_sanitized::kSanitized)
    GTEST_SKIP() << "wall time under AddressSanitizer measures the sanitizer; the Release pass runs this test";
  TempDir d;
  const std::string build = fs::path(MINIMANIP_BINARY).parent_path().string();
  // Another campaign on the same two cores for the whole test (two workers).
  const pid_t load = fork();
  if (load == 0) {
    const std::string cmd = "exec " + std::string(MINIMANIP_BINARY) + " run experiments/quickstart.yaml --trials 100000 --jobs 2 "
                            "--set progress=none --out " + (d.path() / "load").string() + " >/dev/null 2>&1";
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  struct Stop {
    pid_t pid;
    ~Stop() {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  } stop{load};
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const std::string gate = "tools/timing_gate --base " + build + " --candidate " + build + " --out ";
  std::string out;
  int same = shellOut(gate + (d.path() / "same").string() + " 2>&1", out);
  // The same build against itself is asked once more if it fails: beside this campaign, ctest runs
  // another test on the same two cores, whose start or end within one side's trials has moved a
  // median past the limit (CI, 2026-12-02: 1.30 and 1.44 on two runs of three).
  if (same != 0) {
    std::printf("first try:\n%s\n", out.c_str());
    same = shellOut(gate + (d.path() / "same_again").string() + " 2>&1", out);
  }
  EXPECT_EQ(same, 0) << out;
  EXPECT_THAT(out, HasSubstr("PASS  timing.compute_time: median of the 48 trials' ratios"));
  const int slow = shellOut(gate + (d.path() / "slow").string() + " --candidate-set planning.test_time_factor=3 2>&1", out);
  EXPECT_EQ(slow, 1) << out;
  EXPECT_THAT(out, HasSubstr("FAIL  timing.compute_time"));
  EXPECT_THAT(out, HasSubstr("REGRESSION"));
}

}  // namespace
}  // namespace mm
