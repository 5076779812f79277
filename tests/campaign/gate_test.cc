// `minimanip gate`: an unchanged build passes against its baseline, a deliberately slowed planner
// fails (on its exact work counters and, on wall time alone, by Mann-Whitney and the ratio), a loss
// of paired successes fails by McNemar, and bad input is exit 2 before any verdict.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cli_helpers.h"
#include "../sanitized.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;
using ::testing::Not;
using namespace testing_cli;

const std::string kMockAnySeed = "run experiments/quickstart.yaml --set hardware=mock --set progress=none --jobs 2";
const std::string kMock = kMockAnySeed + " --seed 5";

// Counters and timings against a baseline, nothing else.
const std::string kBaselineOnly = R"(experiment: quickstart
baseline:
  counters: [collision_checks, ticks, grasp_candidates_tried, sim_time]
  timings: []
)";
const std::string kTimingOnly = R"(baseline:
  counters: []
  timings: [compute_time, plan_pick_time]
  max_ratio: 1.5
)";

/// Three campaigns of the same trials, run interleaved in blocks (resume extends each): the
/// baseline, the same build again, and the build with a planner slowed `slowdown` times.
struct Interleaved {
  TempDir d;
  std::string base = (d.path() / "base").string(), same = (d.path() / "same").string(), slow = (d.path() / "slow").string();
  Interleaved(int blocks, int per_block, int slowdown) {
    for (int b = 1; b <= blocks; ++b) {
      const std::string n = " --trials " + std::to_string(b * per_block);
      EXPECT_EQ(runMinimanip(kMock + n + " --out " + base).code, 0);
      EXPECT_EQ(runMinimanip(kMock + n + " --out " + same).code, 0);
      EXPECT_EQ(runMinimanip(kMock + n + " --set planning.test_slowdown=" + std::to_string(slowdown) + " --out " + slow).code, 0);
    }
  }
};

TEST(Gate, PassesAnUnchangedBuildAndFailsASlowedPlanner) {
  // The planner slowed 40 times; 10 under the sanitizers (as far past any noise, a quarter of the time).
  Interleaved runs(2, 12, testing_sanitized::sanitizedOr(10, 40));
  const std::string th = runs.d.file("gate.yaml", kBaselineOnly), timing = runs.d.file("timing.yaml", kTimingOnly);

  const RunResult same = runMinimanip("gate " + runs.same + " --thresholds " + th + " --baseline " + runs.base);
  EXPECT_EQ(same.code, 0) << same.out;
  EXPECT_THAT(same.out, HasSubstr("PASS  counter.collision_checks: sum"));
  EXPECT_THAT(same.out, HasSubstr("0 of 24 trials differ"));
  EXPECT_THAT(same.out, HasSubstr("PASS  paired_success: 0 trials lost, 0 gained"));
  EXPECT_THAT(same.out, HasSubstr("detects: "));
  const json verdict = json::parse(std::ifstream(fs::path(runs.same) / "gate.json"));
  EXPECT_EQ(verdict.at("exit_code"), 0);

  // The slowed planner plans the same paths with more checks: the exact counter catches it...
  const RunResult slow = runMinimanip("gate " + runs.slow + " --thresholds " + th + " --baseline " + runs.base);
  EXPECT_EQ(slow.code, 1) << slow.out;
  EXPECT_THAT(slow.out, HasSubstr("FAIL  counter.collision_checks"));
  EXPECT_THAT(slow.out, HasSubstr("PASS  counter.sim_time"));  // same paths, same motions
  EXPECT_THAT(slow.out, HasSubstr("PASS  paired_success"));
  EXPECT_THAT(slow.out, HasSubstr("REGRESSION"));
  // ...and so do its wall timings alone (Mann-Whitney and the ratio). The same build's timings are
  // judged too, but their verdict is not asserted: under ctest -j a busy machine may slow one run
  // (wall time is measured, never asserted; the slowdown is far past any such noise).
  const RunResult slow_t = runMinimanip("gate " + runs.slow + " --thresholds " + timing + " --baseline " + runs.base);
  EXPECT_EQ(slow_t.code, 1) << slow_t.out;
  EXPECT_THAT(slow_t.out, HasSubstr("FAIL  timing.plan_pick_time"));
  EXPECT_THAT(slow_t.out, HasSubstr("at 80% power"));
  const RunResult same_t = runMinimanip("gate " + runs.same + " --thresholds " + timing + " --baseline " + runs.base);
  EXPECT_NE(same_t.code, 2) << same_t.out;
  EXPECT_THAT(same_t.out, HasSubstr("timing.compute_time: median"));

  // A saved baseline file judges as its folder does.
  const std::string file = (runs.d.path() / "baseline.json").string();
  ASSERT_EQ(runMinimanip("gate " + runs.base + " --save-baseline " + file).code, 0);
  const RunResult from_file = runMinimanip("gate " + runs.slow + " --thresholds " + th + " --baseline " + file);
  EXPECT_EQ(from_file.code, 1) << from_file.out;
  EXPECT_THAT(from_file.out, HasSubstr("FAIL  counter.collision_checks"));
}

TEST(Gate, LostSuccessesFailByMcNemarAndYieldsByTheirWilsonBound) {
  TempDir d;
  const std::string base = (d.path() / "base").string(), worse = (d.path() / "worse").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 16 --out " + base).code, 0);
  // The recovery-free tree with a gripper that never closes the first time: most trials fail.
  ASSERT_EQ(runMinimanip(kMock + " --trials 16 --set tree=experiments/trees/pick_place.xml --set faults.gripper_no_close=1 --out " + worse).code,
            0);
  // The tree and fault rate stand in for a build that lost its recovery: allowed to differ.
  const std::string th = d.file("gate.yaml", "yields:\n  overall_yield: 0.7\nbaseline:\n  timings: []\n"
                                             "  config_may_differ: [tree, faults.gripper_no_close]\n");
  const RunResult ok = runMinimanip("gate " + base + " --thresholds " + th + " --baseline " + base);
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_THAT(ok.out, HasSubstr("PASS  overall_yield: 16/16 = 100.0%, Wilson 95% lower bound 80.6%"));
  EXPECT_THAT(ok.out, HasSubstr("detects: fails at 14/16 (87.5%) or fewer"));
  EXPECT_THAT(ok.out, HasSubstr("detects: 6 trials lost with none gained"));
  const RunResult bad = runMinimanip("gate " + worse + " --thresholds " + th + " --baseline " + base);
  EXPECT_EQ(bad.code, 1) << bad.out;
  EXPECT_THAT(bad.out, HasSubstr("FAIL  paired_success"));
  EXPECT_THAT(bad.out, HasSubstr("FAIL  overall_yield"));
}

TEST(Gate, BadInputIsExitTwoNamingTheFile) {
  TempDir d;
  const std::string base = (d.path() / "base").string(), other = (d.path() / "other").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 2 --out " + base).code, 0);
  ASSERT_EQ(runMinimanip(kMockAnySeed + " --trials 2 --seed 6 --out " + other).code, 0);
  const std::string good = d.file("good.yaml", "min_trials: 1\n");
  // The same seed and trials, another configuration: nothing to compare.
  const std::string config = (d.path() / "config").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 2 --set motion.velocity_scaling=0.4 --out " + config).code, 0);
  // A baseline file listing a trial twice.
  const std::string saved = (d.path() / "saved.json").string();
  ASSERT_EQ(runMinimanip("gate " + base + " --save-baseline " + saved).code, 0);
  json b = json::parse(std::ifstream(saved));
  b.at("trials").push_back(b.at("trials").at(0));
  const std::string twice = b.dump();
  struct Case {
    std::string args, says;
  } cases[] = {
      {"gate " + base + " --thresholds " + d.file("typo.yaml", "yields:\n  overal_yield: 0.9\n"), "overal_yield"},
      {"gate " + base + " --thresholds " + d.file("range.yaml", "yields:\n  overall_yield: 1.5\n"), "overall_yield"},
      {"gate " + base + " --thresholds " + d.file("counter.yaml", "baseline:\n  counters: [wall_clock]\n"), "wall_clock"},
      {"gate " + base + " --thresholds " + d.file("name.yaml", "experiment: faults\n"), "experiment 'faults'"},
      {"gate " + base + " --thresholds " + d.file("few.yaml", "min_trials: 20\n"), "need at least 20"},
      {"gate " + base + " --thresholds " + good + " --baseline " + other, "the same seeds"},
      {"gate " + base + " --thresholds " + good + " --baseline " + d.file("junk.json", "{}"), "not a gate baseline"},
      {"gate " + (d.path() / "none").string() + " --thresholds " + good, "not a results folder"},
      {"gate " + base, "--thresholds FILE is required"},
      {"gate " + base + " --thresholds " + d.file("sweep.yaml", "sweep:\n  min_trials: [1, 2]\n"), "no sweep"},
      {"gate " + base + " --thresholds " + good + " --baseline " + config, "another configuration"},
      {"gate " + base + " --thresholds " + good + " --baseline " + d.file("dup.json", twice), "appears twice"},
  };
  for (const Case& c : cases) {
    const RunResult r = runMinimanip(c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_THAT(r.out, HasSubstr(c.says)) << c.args;
    EXPECT_THAT(r.out, Not(HasSubstr("PASS"))) << c.args;
  }
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// A baseline made before an option was declared lacks its key: a run leaving the option at its
// default is the same configuration (a new option's default keeps the old behaviour); one that
// sets it is not.
TEST(Gate, AnOptionDeclaredAfterTheBaselineMattersOnlyAwayFromItsDefault) {
  using namespace testing_cli;
  TempDir d;
  const std::string base = (d.path() / "base").string(), set = (d.path() / "set").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 2 --out " + base).code, 0);
  ASSERT_EQ(runMinimanip(kMock + " --trials 2 --set grasp.payload_compensation=false --out " + set).code, 0);
  const std::string saved = (d.path() / "saved.json").string();
  ASSERT_EQ(runMinimanip("gate " + base + " --save-baseline " + saved).code, 0);
  json b = json::parse(std::ifstream(saved));
  ASSERT_TRUE(b.at("config").contains("grasp.payload_compensation"));
  b.at("config").erase("grasp.payload_compensation");
  const std::string old = d.file("old.json", b.dump());
  const std::string good = d.file("good.yaml", "min_trials: 1\n");
  RunResult r = runMinimanip("gate " + base + " --thresholds " + good + " --baseline " + old);
  EXPECT_EQ(r.code, 0) << r.out;
  r = runMinimanip("gate " + set + " --thresholds " + good + " --baseline " + old);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("grasp.payload_compensation"));
}

TEST(Gate, ReadsTheFieldsItComparesFromRecordsOfAnotherSchema) {
  // tools/timing_gate's base is the previous commit's build, which may write another record schema:
  // its results are read for the gate's own fields, by name; one of those missing is exit 2.
  using namespace testing_cli;
  TempDir d;
  const std::string base = (d.path() / "base").string(), run = (d.path() / "run").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 3 --out " + base).code, 0);
  ASSERT_EQ(runMinimanip(kMock + " --trials 3 --out " + run).code, 0);
  auto rewrite = [&](const std::string& erase) {
    std::ifstream in(fs::path(base) / "trials.jsonl");
    std::string out;
    for (std::string line; std::getline(in, line);) {
      json j = json::parse(line);
      j["schema"] = 3;
      j.erase("picks");  // a field this build's reader needs
      if (!erase.empty()) j.erase(erase);
      out += j.dump() + "\n";
    }
    std::ofstream(fs::path(base) / "trials.jsonl") << out;
  };
  rewrite("");
  const std::string thresholds = d.file("t.yaml", "min_trials: 1\nbaseline:\n  counters: [collision_checks, ticks]\n  timings: []\n");
  RunResult r = runMinimanip("gate " + run + " --baseline " + base + " --thresholds " + thresholds);
  EXPECT_EQ(r.code, 0) << r.out;
  rewrite("ticks");
  r = runMinimanip("gate " + run + " --baseline " + base + " --thresholds " + thresholds);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("trials.jsonl:1"));
  EXPECT_THAT(r.out, HasSubstr("a record of schema 3 without 'ticks'"));
}

}  // namespace
}  // namespace mm
