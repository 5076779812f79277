// Sweeps: an experiment's `sweep:` (or --sweep) runs one campaign per cell of the grid on the same
// seed, each cell equal to the campaign run alone with those settings; the report plots each
// factor; a folder of another sweep and an unsweepable or invalid factor are exit 2.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>

#include "cli_helpers.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;
using namespace testing_cli;

const std::string kMock = "run experiments/quickstart.yaml --set hardware=mock --set progress=none --seed 4 --trials 6 --jobs 2";

TEST(Sweep, EachCellEqualsItsCampaignRunAloneAndTheReportPlotsEachFactor) {
  TempDir d;
  const std::string out = (d.path() / "sweep").string();
  const RunResult r = runMinimanip(kMock + " --sweep objects.count_max=1,3 --sweep faults.gripper_no_close=0,1 --set "
                                           "tree=experiments/trees/pick_place.xml --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("cell_003  objects.count_max=3 faults.gripper_no_close=1"));
  const json sweep = json::parse(std::ifstream(fs::path(out) / "sweep.json"));
  ASSERT_EQ(sweep["cells"].size(), 4u);
  EXPECT_EQ(sweep["cells"][2]["settings"], (json{{"objects.count_max", "3"}, {"faults.gripper_no_close", "0"}}));
  // A cell is the campaign with its settings, trial for trial.
  const std::string alone = (d.path() / "alone").string();
  ASSERT_EQ(runMinimanip(kMock + " --set tree=experiments/trees/pick_place.xml --set objects.count_max=3 --set "
                                 "faults.gripper_no_close=1 --out " + alone).code, 0);
  const auto a = readTrials(alone), c = readTrials(fs::path(out) / "cell_003");
  ASSERT_EQ(a.size(), c.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(outcomeFields(a[i]), outcomeFields(c[i])) << "trial " << i;
  // The factor bites: a gripper that never closes the first time fails the recovery-free tree.
  const json ok = json::parse(std::ifstream(fs::path(out) / "cell_000" / "summary.json"));
  const json bad = json::parse(std::ifstream(fs::path(out) / "cell_001" / "summary.json"));
  EXPECT_GT(ok["overall_yield"]["value"].get<double>(), bad["overall_yield"]["value"].get<double>());

  // Run again: every cell resumes with nothing to do; another grid in the folder is refused.
  EXPECT_EQ(runMinimanip(kMock + " --sweep objects.count_max=1,3 --sweep faults.gripper_no_close=0,1 --set "
                                 "tree=experiments/trees/pick_place.xml --out " + out).code, 0);
  const RunResult other = runMinimanip(kMock + " --sweep objects.count_max=1,2 --out " + out);
  EXPECT_EQ(other.code, 2) << other.out;
  EXPECT_THAT(other.out, HasSubstr("holds another sweep"));

  const RunResult rep = runMinimanip("report " + out);
  ASSERT_EQ(rep.code, 0) << rep.out;
  std::stringstream html;
  html << std::ifstream(fs::path(out) / "report.html").rdbuf();
  for (const char* id : {"sweep0_yield", "sweep0_recovery", "sweep0_cycle", "sweep1_yield", "sweep1_recovery", "sweep1_cycle"})
    EXPECT_THAT(html.str(), HasSubstr(std::string("data-plot=\"") + id + "\"")) << id;
  EXPECT_THAT(html.str(), HasSubstr("Against faults.gripper_no_close"));
  // The pooled bar of gripper_no_close = 1: cells 1 and 3.
  const json c1 = json::parse(std::ifstream(fs::path(out) / "cell_001" / "summary.json")),
             c3 = json::parse(std::ifstream(fs::path(out) / "cell_003" / "summary.json"));
  const long k = c1["successes"].get<long>() + c3["successes"].get<long>();
  EXPECT_THAT(html.str(), HasSubstr(std::to_string(k) + "/12 = "));

  // Headless Chromium lays out all six plots, and the cells' yields it shows are their summaries'.
  std::string said;
  if (shellOut("command -v chromium", said) != 0) {
    if (std::getenv("MINIMANIP_CI")) FAIL() << "under CI the sweep report may not skip Chromium: it is not installed";
    GTEST_SKIP() << "chromium is not installed (tools/setup installs it)";
  }
  const std::string dom = renderInChromium(fs::path(out) / "report.html", d.path());
  EXPECT_THAT(dom, HasSubstr("data-plots-drawn=\"6\""));
  for (int i = 0; i < 4; ++i) {
    const json s = json::parse(std::ifstream(fs::path(out) / ("cell_00" + std::to_string(i)) / "summary.json"));
    char want[64];
    std::snprintf(want, sizeof want, "data-key=\"cell%d.yield\">%.1f%%<", i, 100 * s["overall_yield"]["value"].get<double>());
    EXPECT_THAT(dom, HasSubstr(want));
  }
}

TEST(Sweep, BadFactorsAreExitTwoBeforeAnyTrial) {
  TempDir d;
  const std::string out = (d.path() / "o").string();
  struct Case {
    std::string args, says;
  } cases[] = {
      {" --sweep objects.count_max=1,101", "count_max"},           // out of range
      {" --sweep objects.count_max=3", "at least two values"},
      {" --sweep seed=1,2", "cannot be swept"},
      {" --sweep objects.nonsense=1,2", "nonsense"},
      {" --sweep objects.count_max=1,3 --set objects.count_max=2", "both swept and set"},
      {" --sweep grasp.yaw_offsets=0,1", "cannot be swept"},
  };
  for (const Case& c : cases) {
    const RunResult r = runMinimanip(kMock + c.args + " --out " + out);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_THAT(r.out, HasSubstr(c.says)) << c.args;
    EXPECT_FALSE(fs::exists(fs::path(out) / "cell_000" / "trials.jsonl")) << c.args;
  }
  // In a file: sweep: with a list per key.
  const std::string file = d.file("s.yaml", "name: s\ntrials: 2\nhardware: mock\nsweep:\n  objects.count_max: 2\n");
  const RunResult r = runMinimanip("run " + file + " --out " + out);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("s.yaml:5:3"));
  // Cross-key checks apply to each cell's values, not the file's own (count_max 1 < count_min 2 in a cell).
  const RunResult cross = runMinimanip(kMock + " --set objects.count_min=2 --sweep objects.count_max=1,3 --out " + out);
  EXPECT_EQ(cross.code, 2) << cross.out;
  EXPECT_THAT(cross.out, HasSubstr("count_min"));
  EXPECT_FALSE(fs::exists(fs::path(out) / "cell_001")) << cross.out;
}

TEST(Sweep, AFilesPathValuesAreRelativeToItAndOneCellReplaysAlone) {
  TempDir d;
  // The file lives outside the repository; its swept tree paths are relative to it.
  const fs::path trees = fs::path(MINIMANIP_SOURCE_DIR) / "experiments" / "trees";
  fs::create_directories(d.path() / "mine");
  fs::copy_file(trees / "pick_place.xml", d.path() / "mine" / "plain.xml");
  fs::copy_file(trees / "recovering_pick_place.xml", d.path() / "mine" / "recover.xml");
  const std::string file = d.file("sweep.yaml", "name: s\ntrials: 3\nseed: 4\nhardware: mock\nprogress: none\n"
                                                "faults:\n  gripper_no_close: 1\n"
                                                "sweep:\n  tree: [mine/plain.xml, mine/recover.xml]\n");
  const std::string out = (d.path() / "out").string();
  const RunResult r = runMinimanip("run " + file + " --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  const json plain = json::parse(std::ifstream(fs::path(out) / "cell_000" / "summary.json"));
  const json recover = json::parse(std::ifstream(fs::path(out) / "cell_001" / "summary.json"));
  EXPECT_LT(plain["overall_yield"]["value"].get<double>(), recover["overall_yield"]["value"].get<double>());
  // A plain campaign cannot run into the sweep's folder...
  const RunResult into = runMinimanip("run " + file + " --no-sweep --out " + out);
  EXPECT_EQ(into.code, 2) << into.out;
  EXPECT_THAT(into.out, HasSubstr("holds a sweep"));
  // ...but one cell replays alone with --no-sweep and its value as --set, trial for trial.
  const std::string alone = (d.path() / "alone").string();
  const RunResult one = runMinimanip("run " + file + " --no-sweep --set tree=" + (d.path() / "mine" / "recover.xml").string() +
                                     " --out " + alone);
  ASSERT_EQ(one.code, 0) << one.out;
  const auto a = readTrials(alone), c = readTrials(fs::path(out) / "cell_001");
  ASSERT_EQ(a.size(), c.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(outcomeFields(a[i]), outcomeFields(c[i])) << "trial " << i;
}

}  // namespace
}  // namespace mm
