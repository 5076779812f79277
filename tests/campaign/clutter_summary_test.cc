// The clutter-removal protocol's figures: grasp success rate (attempts whose object reached the
// tray / attempts) and declutter rate (objects in the tray / objects), overall and per shape grade,
// with Wilson intervals; and a real round of generated objects records them consistently.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "../campaign/cli_helpers.h"
#include "campaign/record.h"
#include "campaign/stats.h"

namespace mm {
namespace {

using testing_cli::runMinimanip;
using testing_cli::TempDir;

PickRecord inTray(int object) {
  PickRecord p;
  p.object = object;
  p.at_target = true;
  return p;
}

TEST(ClutterSummary, RatesOverallAndPerGrade) {
  TrialRecord a;
  a.objects_in_bin = 3;
  a.object_grades = {"convex", "bent", "convex"};
  // Object 0 on the first try; object 1 missed once, then dropped; object 2 once, to the tray,
  // and a closing near no object.
  a.o.grasp_attempts = {{0, "in_tray"}, {1, "missed"}, {1, "dropped"}, {2, "in_tray"}, {-1, "missed"}};
  a.o.picks = {inTray(0), inTray(2)};
  TrialRecord b;
  b.objects_in_bin = 2;
  b.object_grades = {"hollow", "bent"};
  b.o.grasp_attempts = {{1, "in_tray"}};
  b.o.picks = {inTray(1), inTray(1)};  // the same object twice counts once
  const CampaignSummary s = summarizeTrials({a, b});
  EXPECT_EQ(s.clutter.grasp_success.k, 3);
  EXPECT_EQ(s.clutter.grasp_success.n, 6);
  EXPECT_DOUBLE_EQ(s.clutter.grasp_success.value, 0.5);
  const auto [lo, hi] = wilson95(3, 6);
  EXPECT_EQ(s.clutter.grasp_success.ci95, (std::vector<double>{lo, hi}));
  EXPECT_EQ(s.clutter.declutter.k, 3);
  EXPECT_EQ(s.clutter.declutter.n, 5);
  EXPECT_EQ(s.attempt_results.at("in_tray"), 3);
  EXPECT_EQ(s.attempt_results.at("missed"), 2);
  EXPECT_EQ(s.attempt_results.at("dropped"), 1);
  ASSERT_EQ(s.clutter_by_grade.size(), 3u);
  // Simplest first, as the generator orders its grades.
  EXPECT_EQ(s.clutter_by_grade[0].grade, "convex");
  EXPECT_EQ(s.clutter_by_grade[1].grade, "bent");
  EXPECT_EQ(s.clutter_by_grade[2].grade, "hollow");
  const ClutterStats& convex = s.clutter_by_grade[0];
  EXPECT_EQ(convex.declutter.n, 2);
  EXPECT_EQ(convex.grasp_success.k, 2);
  EXPECT_EQ(convex.grasp_success.n, 2);
  EXPECT_EQ(convex.declutter.k, 2);
  const ClutterStats& bent = s.clutter_by_grade[1];
  EXPECT_EQ(bent.declutter.n, 2);
  EXPECT_EQ(bent.grasp_success.k, 1);
  EXPECT_EQ(bent.grasp_success.n, 3);
  EXPECT_EQ(bent.declutter.k, 1);
  const ClutterStats& hollow = s.clutter_by_grade[2];
  EXPECT_EQ(hollow.declutter.n, 1);
  EXPECT_EQ(hollow.grasp_success.n, 0);
  EXPECT_EQ(hollow.grasp_success.value, -1) << "no attempt: no rate";
  EXPECT_TRUE(hollow.grasp_success.ci95.empty());
  EXPECT_EQ(hollow.declutter.k, 0);
  // Written and read back.
  CampaignSummary copy = s;
  const CampaignSummary back = summaryFromJson(toJson(copy), "summary.json");
  ASSERT_EQ(back.clutter_by_grade.size(), 3u);
  EXPECT_EQ(back.clutter_by_grade[1].grasp_success.n, 3);
  EXPECT_EQ(back.clutter.declutter.value, s.clutter.declutter.value);
}

TEST(ClutterSummary, ARoundOfGeneratedObjectsRecordsItsAttempts) {
  TempDir dir;
  const std::string out = (dir.path() / "pile").string();
  const auto r = runMinimanip("run experiments/clutter_pile.yaml --trials 2 --jobs 2 --set progress=none --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("Clutter removal"));
  long attempts = 0, in_tray = 0, objects = 0;
  std::ifstream in(out + "/trials.jsonl");
  for (std::string line; std::getline(in, line);) {
    const TrialRecord t = fromJsonLine(line, "trials.jsonl");
    ASSERT_EQ(t.object_grades.size(), static_cast<size_t>(t.objects_in_bin));
    EXPECT_EQ(t.o.tree_status, "SUCCESS") << "the round ends by its rule (the bin empty, or two failures in a row), not by a budget";
    objects += t.objects_in_bin;
    for (const GraspAttempt& a : t.o.grasp_attempts) {
      ++attempts;
      if (!a.success()) continue;
      ++in_tray;
      const bool placed = std::any_of(t.o.picks.begin(), t.o.picks.end(), [&](const PickRecord& p) { return p.object == a.object && p.at_target; });
      EXPECT_TRUE(placed) << "an attempt in the tray is an object let go of at its target";
    }
  }
  const auto s = nlohmann::json::parse(std::ifstream(out + "/summary.json"));
  EXPECT_EQ(s["grasp_success_rate"]["n"].get<long>(), attempts);
  EXPECT_EQ(s["grasp_success_rate"]["k"].get<long>(), in_tray);
  EXPECT_EQ(s["declutter_rate"]["n"].get<long>(), objects);
  EXPECT_GE(s["clutter_by_grade"].size(), 1u);
}

TEST(ClutterSummary, AttemptsThatFailSayHow) {
  // Every closing is blocked (the gripper does not close): missed; every grasp slips: dropped.
  for (const auto& [fault, result] : {std::pair<std::string, std::string>{"gripper_no_close", "missed"}, {"grasp_slip", "dropped"}}) {
    TempDir dir;
    const std::string out = (dir.path() / fault).string();
    const auto r = runMinimanip("run experiments/quickstart.yaml --trials 2 --set progress=none --set faults." + fault + "=1 --out " + out);
    ASSERT_EQ(r.code, 0) << r.out;
    std::ifstream in(out + "/trials.jsonl");
    int n = 0;
    for (std::string line; std::getline(in, line);) {
      const TrialRecord t = fromJsonLine(line, "trials.jsonl");
      ASSERT_FALSE(t.o.grasp_attempts.empty()) << fault;
      EXPECT_EQ(t.o.grasp_attempts.front().result, result) << fault;
      EXPECT_GE(t.o.grasp_attempts.front().object, 0) << "the object the fingers closed on, or nearest";
      ++n;
    }
    EXPECT_EQ(n, 2);
  }
}

}  // namespace
}  // namespace mm
