// trials.jsonl and summary.json come from one description of their fields: a campaign's lines
// read back into records and written again are the same lines, and the summary recomputed from
// the read-back records equals the one the campaign wrote.
#include "campaign/record.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

TEST(Records, TrialLinesReadBackAndTheSummaryIsRecomputedFromThem) {
  const fs::path dir = fs::temp_directory_path() / ("mm_records_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const std::string cmd = std::string(MINIMANIP_BINARY) + " run experiments/quickstart.yaml --trials 4 --set hardware=mock " +
                          "--set progress=none --set tree=experiments/trees/bin_picking_fixed.xml --out " + dir.string() +
                          " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(dir / "trials.jsonl");
  std::vector<TrialRecord> records;
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    TrialRecord r = fromJsonLine(line, "trials.jsonl:" + std::to_string(++n));
    EXPECT_EQ(toJsonLine(r), line);
    EXPECT_EQ(nlohmann::json::parse(line).at("oracle"), "poses") << "ground truth: the simulator's poses";
    records.push_back(std::move(r));
  }
  ASSERT_EQ(records.size(), 4u);
  EXPECT_GT(records[0].o.picks.size(), 0u);
  CampaignSummary again = summarizeTrials(records);
  auto written = nlohmann::json::parse(std::ifstream(dir / "summary.json"));
  auto recomputed = nlohmann::json::parse(toJson(again));
  for (const char* k : {"trials", "successes", "first_pass_yield", "overall_yield", "cycle_time", "sim_time",
                        "throughput_per_hour", "mean_time_breakdown", "place_position_error_mm", "objects_placed",
                        "objects_left_in_bin", "bins_cleared", "failure_stages"})
    EXPECT_EQ(written[k], recomputed[k]) << k;
  fs::remove_all(dir);
}

// A run given what no real cell has says so in every trial record, not only in its
// config.resolved.yaml: camera mode's points cut by the renderer's labels.
TEST(Records, AnOracleRunSaysSoInEveryRecord) {
  const fs::path dir = fs::temp_directory_path() / ("mm_records_oracle_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const std::string cmd = std::string(MINIMANIP_BINARY) + " run experiments/clutter_pile.yaml --trials 2 --only 0 --set progress=none " +
                          "--set tree=experiments/trees/clutter_removal_cloud.xml --set perception.mode=camera " +
                          "--set perception.segmentation=labels --out " + dir.string() + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(dir / "trials.jsonl");
  int n = 0;
  for (std::string line; std::getline(in, line); ++n) {
    EXPECT_EQ(nlohmann::json::parse(line).at("oracle"), "segmentation");
    EXPECT_EQ(fromJsonLine(line, "trials.jsonl").oracle, "segmentation");
  }
  EXPECT_EQ(n, 1);
  fs::remove_all(dir);
}

TEST(Records, ALineThatIsNotATrialRecordIsBadInput) {
  EXPECT_THROW(fromJsonLine("{\"trial\": 1}", "x.jsonl:1"), InputError);
  EXPECT_THROW(fromJsonLine("{\"schema\": 2, \"trial\"", "x.jsonl:2"), InputError);
}

TEST(Records, ARecordOfAnotherBuildSaysSoBeforeAnyMissingField) {
  try {
    fromJsonLine("{\"schema\": 2, \"trial\": 0}", "old/trials.jsonl:1");
    FAIL() << "an old record was read";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("old/trials.jsonl:1"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("schema 2, written by another build"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("new --out"));
  }
}

TEST(Records, EveryFieldIsDocumented) {
  const std::string md = recordsMarkdown();
  for (const char* k : {"`failure_kind`", "`picks`", "`bt_log`", "`stages`", "`overall_yield`", "`time_per_pick`"})
    EXPECT_THAT(md, ::testing::HasSubstr(k));
}

}  // namespace
}  // namespace mm
