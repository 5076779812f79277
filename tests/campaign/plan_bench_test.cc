// plan-bench end to end on a small problem set, and its OMPL log checked against the grammar of
// OMPL's "benchmark logfile format" (the EBNF ompl_benchmark_statistics.py follows).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "campaign/plan_bench.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

// A recursive-descent reading of the log by the EBNF; throws std::runtime_error with the line.
struct LogParser {
  std::vector<std::string> lines;
  size_t i = 0;
  int planners = 0, runs_total = 0;
  explicit LogParser(const std::string& path) {
    std::ifstream in(path);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  const std::string& next() {
    if (i >= lines.size()) throw std::runtime_error("unexpected end of log");
    return lines[i++];
  }
  void expect(const std::regex& re, const std::string& what) {
    const std::string& l = next();
    if (!std::regex_match(l, re)) throw std::runtime_error("line " + std::to_string(i) + ": expected " + what + ", got '" + l + "'");
  }
  int expectCount(const std::string& suffix) {
    const std::string& l = next();
    std::smatch m;
    if (!std::regex_match(l, m, std::regex("([0-9]+)" + suffix)))
      throw std::runtime_error("line " + std::to_string(i) + ": expected '<int>" + suffix + "', got '" + l + "'");
    return std::stoi(m[1]);
  }
  void multiLine() {
    expect(std::regex("<<<\\|"), "<<<|");
    while (next() != "|>>>") {
    }
  }
  void parse() {
    const std::string num = "(-?[0-9.]+(e[-+]?[0-9]+)?|inf|nan)";
    expect(std::regex("\\S+ version \\S+"), "version");
    expect(std::regex("Experiment \\S+"), "experiment");
    if (std::regex_match(lines[i], std::regex("[0-9]+ experiment properties"))) {
      const int n = expectCount(" experiment properties");
      for (int k = 0; k < n; ++k) expect(std::regex("\\S+ (BOOLEAN|INTEGER|REAL)=" + num), "experiment property");
    }
    expect(std::regex("Running on .+"), "hostname");
    expect(std::regex("Starting at .+"), "date");
    multiLine();                                      // setup
    if (lines[i] == "<<<|") multiLine();              // cpuinfo
    expect(std::regex("[0-9]+ is the random seed"), "random seed");
    expect(std::regex(num + " seconds per run"), "time limit");
    expect(std::regex(num + " MB per run"), "memory limit");
    int runs = -1;
    if (std::regex_match(lines[i], std::regex("[0-9]+ runs per planner"))) runs = expectCount(" runs per planner");
    expect(std::regex(num + " seconds spent to collect the data"), "total time");
    if (std::regex_match(lines[i], std::regex("[0-9]+ enum type"))) {
      const int n = expectCount(" enum type");
      for (int k = 0; k < n; ++k) expect(std::regex("\\S+(\\|[^|]+)+"), "enum");
    }
    planners = expectCount(" planners");
    for (int p = 0; p < planners; ++p) {
      expect(std::regex("\\S+"), "planner name");
      const int common = expectCount(" common properties");
      for (int k = 0; k < common; ++k) expect(std::regex(".+ = .*"), "planner property");
      const int props = expectCount(" properties for each run");
      for (int k = 0; k < props; ++k) expect(std::regex(".+ (BOOLEAN|INTEGER|REAL)"), "run property");
      const int n = expectCount(" runs");
      if (runs >= 0 && n != runs) throw std::runtime_error("runs per planner mismatch");
      const std::regex data("((" + num + ")?; ){" + std::to_string(props) + "}");
      for (int k = 0; k < n; ++k) expect(data, std::to_string(props) + " '; '-terminated values");
      runs_total += n;
      expect(std::regex("\\."), "'.' closing the planner block");
    }
    if (i != lines.size()) throw std::runtime_error("trailing lines after the last planner");
  }
};

TEST(PlanBench, SmallRunWritesResultsAndAParsableOmplLog) {
  const fs::path out = fs::temp_directory_path() / ("mm_planbench_" + std::to_string(getpid()));
  PlanBenchOptions o;
  o.scenes = 2;
  o.seed = 3;
  o.planners = {"RRTConnect", "PRMstar"};
  o.checkers = {"spheres", "fcl"};
  o.time_limit = 10.0;
  o.out_dir = out.string();
  o.command_line = "plan_bench_test";
  const std::string md = runPlanBench(o);
  EXPECT_THAT(md, ::testing::HasSubstr("| RRTConnect | spheres |"));
  EXPECT_THAT(md, ::testing::HasSubstr("jerk_limited"));
  LogParser log((out / "plan_bench.log").string());
  ASSERT_NO_THROW(log.parse());
  EXPECT_EQ(log.planners, 4);
  const auto j = nlohmann::json::parse(std::ifstream(out / "plan_bench.json"));
  ASSERT_EQ(j["combinations"].size(), 4u);
  const int problems = j["problems"];
  EXPECT_GE(problems, 3);
  EXPECT_EQ(log.runs_total, 4 * problems);
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
