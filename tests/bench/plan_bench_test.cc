// plan-bench end to end on a small problem set, and its OMPL log loaded by OMPL's own
// ompl_benchmark_statistics into the database Planner Arena reads.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "bench/plan_bench.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

std::string shell(const std::string& cmd, int& code) {
  std::string out;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  code = WEXITSTATUS(pclose(p));
  return out;
}

// One value of a query on an sqlite database (the sqlite3 tool).
std::string sql(const fs::path& db, const std::string& query) {
  int code = 0;
  std::string out = shell("sqlite3 " + db.string() + " \"" + query + "\"", code);
  EXPECT_EQ(code, 0) << out;
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

TEST(PlanBench, SmallRunWritesResultsAndAParsableOmplLog) {
  const fs::path out = fs::temp_directory_path() / ("mm_planbench_" + std::to_string(getpid()));
  PlanBenchOptions o;
  o.scenes = 2;
  o.seed = 3;
  o.planners = {"RRTConnect", "PRMstar"};
  o.checkers = {"spheres", "fcl"};
  o.time_limit = 60.0;  // generous: the wall-clock cap must not decide success on a loaded machine
  o.out_dir = out.string();
  o.command_line = "plan_bench_test";
  const std::string md = runPlanBench(o);
  EXPECT_THAT(md, ::testing::HasSubstr("| RRTConnect | spheres |"));
  EXPECT_THAT(md, ::testing::HasSubstr("jerk_limited"));
  const auto j = nlohmann::json::parse(std::ifstream(out / "plan_bench.json"));
  ASSERT_EQ(j["combinations"].size(), 4u);
  const int problems = j["problems"];
  EXPECT_GE(problems, 3);
  // The OMPL log through OMPL's own tool (Debian's ompl-demos), into the database Planner Arena reads.
  int code = 0;
  const fs::path db = out / "bench.db";
  const std::string said = shell("ompl_benchmark_statistics " + (out / "plan_bench.log").string() + " -d " + db.string(), code);
  ASSERT_EQ(code, 0) << said;
  EXPECT_EQ(sql(db, "SELECT count(*) FROM experiments"), "1");
  EXPECT_EQ(sql(db, "SELECT name FROM experiments"), "minimanip_bin_scene");
  EXPECT_EQ(sql(db, "SELECT problems FROM experiments"), std::to_string(problems));
  EXPECT_EQ(sql(db, "SELECT padding FROM experiments"), "0.01");
  EXPECT_EQ(sql(db, "SELECT runcount FROM experiments"), std::to_string(problems));
  EXPECT_EQ(sql(db, "SELECT count(*) FROM plannerConfigs"), "4");
  EXPECT_EQ(sql(db, "SELECT name FROM plannerConfigs ORDER BY id LIMIT 1"), "geometric_RRTConnect_spheres");
  EXPECT_EQ(sql(db, "SELECT count(*) FROM runs"), std::to_string(4 * problems));
  EXPECT_EQ(sql(db, "SELECT count(*) FROM runs WHERE solved = 1"), std::to_string(4 * problems));
  EXPECT_EQ(sql(db, "SELECT count(*) FROM runs WHERE time > 0 AND trajectory_duration_jerk_limited > 0"),
            std::to_string(4 * problems));
  for (const auto& c : j["combinations"]) {
    EXPECT_EQ(c["success"], 1.0) << c["planner"] << "+" << c["checker"];
    for (const auto& tp : c["time_parameterizations"]) EXPECT_EQ(tp["within_limits"], tp["n"]);
    // Every method ran on every solved problem; passing through waypoints never loses to stopping
    // at them by more than the rounding to periods.
    for (const auto& r : c["runs"]) {
      ASSERT_EQ(r["durations_s"].size(), 4u);
      EXPECT_LE(r["durations_s"]["jerk_limited"].get<double>(),
                r["durations_s"]["jerk_limited_stop"].get<double>() + 0.006 * (1 + r["length"].get<double>()));
    }
  }
  fs::remove_all(out);
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// The cluttered set blocks direct motions: some simplified paths need intermediate waypoints, and
// the through-waypoint jerk-limited trajectories then pass some of them at speed.
TEST(PlanBench, ClutteredProblemsNeedDetours) {
  const fs::path out = fs::temp_directory_path() / ("mm_planbench_clutter_" + std::to_string(getpid()));
  PlanBenchOptions o;
  o.scenes = 10;
  o.seed = 5;
  o.problems = "clutter";
  o.planners = {"RRTConnect"};
  o.checkers = {"spheres+fcl"};
  // The wall-clock cap must not decide success here: under the sanitizers on a loaded 2-core
  // machine one of the 26 problems once needed more than the default 5 s.
  o.time_limit = 120;
  o.out_dir = out.string();
  o.command_line = "plan_bench_test";
  runPlanBench(o);
  const auto j = nlohmann::json::parse(std::ifstream(out / "plan_bench.json"));
  EXPECT_EQ(j["problem_set"], "clutter");
  const auto& c = j["combinations"][0];
  EXPECT_EQ(c["success"], 1.0);
  const auto& jl = c["time_parameterizations"]["jerk_limited"];
  EXPECT_GT(jl["interior_waypoints"].get<int>(), 0);
  EXPECT_LT(jl["stops"].get<int>(), jl["interior_waypoints"].get<int>());
  EXPECT_EQ(jl["within_limits"], jl["n"]);
  fs::remove_all(out);
}

}  // namespace
}  // namespace mm
