// The quickstart's 100 trials of seed 1 against recorded outcomes
// (tests/reference/quickstart_seed1_chain.jsonl): success, failure stage, target, place errors,
// collisions, simulated times and the stages with their simulated durations must be the same.
// First recorded from the pick-and-place chain before the task layer became actions; re-recorded
// 2026-11-23 when plans began to end (and straight lines to start) where the previous trajectory
// ends, from the pick_place tree, `minimanip bench` showing the tree-less chain with the same
// success and simulated time on every trial; re-recorded the same day when each trial's model came
// to hold only the objects in play (no parked pool): the same success on all 100, place errors
// within 0.029 mm, stage durations within a few steps; and again with the place-error fix
// (the pads govern their contacts, the servo compensates the payload: place errors
// 2.84 -> 0.42 mm mean, the fingers close and open sooner on the stiffer pads), by design; and
// again 2026-11-24, by design: the quickstart became the fast cell (full joint limits,
// 0.5 m/s lines with jerk limits, blends at the pre-grasp and pre-place, early closing: cycle
// 7.35 -> 3.92 s), the contacts got the velocity-product term (no creep along the pads) and a
// release lets go before the retreat (place errors 0.42 -> 0.23 mm mean); and the same day when
// objects at rest began to sleep (place errors changed by 0.01 um, stages and times not at all);
// and 2026-11-25 when sleeping came to judge "something within 2 cm" by the shapes' gap instead of
// their bounding spheres (place errors within 0.03 um, the rest the same).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include "../sanitized.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::vector<json> readJsonl(const fs::path& file) {
  std::vector<json> v;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) v.push_back(json::parse(line));
  std::sort(v.begin(), v.end(), [](const json& a, const json& b) { return a["trial"] < b["trial"]; });
  return v;
}

std::string stagesText(const json& t) {
  std::ostringstream s;
  for (const json& st : t["stages"]) {
    if (s.tellp() > 0) s << " ";
    s << st["name"].get<std::string>() << ":" << std::lround(st["sim_seconds"].get<double>() * 1000)
      << (st["ok"].get<bool>() ? "" : "!");
  }
  return s.str();
}

// `extra` selects how the campaign runs (the tree, once there is one); outcomes must not change.
// All 100 recorded trials; the first 40 under the sanitizers.
void expectSameAsReference(const std::string& extra) {
  const size_t trials = testing_sanitized::sanitizedOr(40, 100);
  const fs::path out = fs::temp_directory_path() / ("mm_reference_" + std::to_string(getpid()));
  fs::remove_all(out);
  const std::string cmd = std::string(MINIMANIP_BINARY) +
                          " run experiments/quickstart.yaml --trials " + std::to_string(trials) + " --seed 1 --jobs 2 --set progress=none " +
                          extra + " --out " + out.string() + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const auto ref = readJsonl("tests/reference/quickstart_seed1_chain.jsonl");
  const auto got = readJsonl(out / "trials.jsonl");
  ASSERT_EQ(ref.size(), 100u);
  ASSERT_EQ(got.size(), trials);
  for (size_t i = 0; i < trials; ++i) {
    const json& r = ref[i];
    const json& t = got[i];
    SCOPED_TRACE("trial " + std::to_string(i));
    for (const char* k : {"success", "failure_stage", "target_object", "objects_in_bin", "grasp_candidates_tried",
                          "collision_count", "dropped", "sim_unstable"})
      EXPECT_EQ(r[k], t[k]) << k;
    for (const char* k : {"grasp_opening", "place_position_error", "place_orientation_error", "max_tracking_error"})
      EXPECT_NEAR(r[k].get<double>(), t[k].get<double>(), 1e-9) << k;
    EXPECT_NEAR(r["sim_time"].get<double>(), t["sim_time"].get<double>(), 1e-6);
    for (const char* k : {"execute_pick_time", "execute_place_time"})
      EXPECT_NEAR(r[k].get<double>(), t["cycle"][k].get<double>(), 1e-6) << k;
    EXPECT_EQ(r["stages"].get<std::string>(), stagesText(t));
  }
  fs::remove_all(out);
}

// The recovery-free tree over the node library gives the outcomes of the chain it replaced.
TEST(Reference, PickPlaceTreeMatchesTheRecordedChainOnQuickstartSeed1) {
  expectSameAsReference("--set tree=experiments/trees/pick_place.xml");
}

}  // namespace
}  // namespace mm
