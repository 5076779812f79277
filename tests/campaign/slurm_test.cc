// A real single-node Slurm (Debian's slurm-wlm and munge, started by tools/slurm/local_cluster in a
// temporary folder, stopped by PID afterwards) runs a campaign as an array of three shards and the
// merge job; the merged results equal a local run of the same campaign. Outside CI it skips, saying
// why, where the packages or root are missing; with MINIMANIP_CI set (.ci/run) it may not skip.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>

#include "cli_helpers.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace testing_cli;

int shell(const std::string& cmd, std::string* out = nullptr) {
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  char buf[4096];
  std::string text;
  while (size_t n = fread(buf, 1, sizeof buf, p)) text.append(buf, n);
  const int status = pclose(p);
  if (out) *out = text;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(Slurm, AShardedArrayCampaignMergedEqualsALocalRun) {
  const bool ci = std::getenv("MINIMANIP_CI") != nullptr;
  std::string why;
  if (geteuid() != 0) why = "needs root (munged runs as the munge user)";
  else if (shell("command -v slurmctld && command -v slurmd && command -v sbatch && command -v munged") != 0)
    why = "slurm-wlm and munge are not installed (tools/setup installs them)";
  if (!why.empty()) {
    if (ci) FAIL() << "under CI the Slurm test may not skip: " << why;
    GTEST_SKIP() << why;
  }
  TempDir d;
  chmod(d.path().c_str(), 0755);  // the munge user walks into it
  const std::string cluster = (d.path() / "cluster").string();
  std::string said;
  ASSERT_EQ(shell("tools/slurm/local_cluster start " + cluster, &said), 0) << said;
  const std::string conf = "SLURM_CONF=" + cluster + "/slurm/slurm.conf ";
  const std::string args = " experiments/quickstart.yaml --trials 9 --seed 4 --set hardware=mock --set bt.log=all";
  const fs::path campaign = d.path() / "campaign";
  const int submitted = shell(conf + "tools/slurm/submit --wait 3 " + campaign.string() + args, &said);
  shell("tools/slurm/local_cluster stop " + cluster);
  ASSERT_EQ(submitted, 0) << said;
  for (int k = 0; k < 3; ++k) EXPECT_EQ(readTrials(campaign / ("shard_" + std::to_string(k))).size(), 3u) << "shard " << k;
  ASSERT_EQ(runMinimanip("run" + args + " --set progress=none --out " + (d.path() / "local").string()).code, 0);
  const auto merged = readTrials(campaign / "merged"), local = readTrials(d.path() / "local");
  ASSERT_EQ(merged.size(), 9u);
  ASSERT_EQ(local.size(), 9u);
  for (size_t i = 0; i < merged.size(); ++i) {
    EXPECT_EQ(outcomeFields(merged[i]), outcomeFields(local[i])) << "trial " << i;
    EXPECT_TRUE(fs::exists(campaign / "merged" / merged[i]["bt_log"].get<std::string>()));
  }
  const json a = json::parse(std::ifstream(campaign / "merged" / "summary.json"));
  const json b = json::parse(std::ifstream(d.path() / "local" / "summary.json"));
  for (const char* k : {"trials", "successes", "objects_placed", "collision_events", "sim_time", "place_position_error_mm"})
    EXPECT_EQ(a[k], b[k]) << k;
}

// merge refuses folders that do not make one campaign: exit 2, nothing written.
TEST(Merge, RefusesAMissingShardADoubledOneAndAnotherConfiguration) {
  TempDir d;
  const std::string base = "run experiments/quickstart.yaml --trials 6 --seed 2 --set hardware=mock --set progress=none";
  for (int k = 0; k < 2; ++k)
    ASSERT_EQ(runMinimanip(base + " --shard " + std::to_string(k) + "/2 --out " + (d.path() / std::to_string(k)).string()).code, 0);
  ASSERT_EQ(runMinimanip(base + " --shard 1/2 --set objects.count_max=2 --out " + (d.path() / "other").string()).code, 0);
  const std::string s0 = (d.path() / "0").string(), s1 = (d.path() / "1").string(), other = (d.path() / "other").string();
  const std::string out = (d.path() / "merged").string();
  RunResult r = runMinimanip("merge --out " + out + " " + s0);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.out, ::testing::HasSubstr("3 of the 6 trials are in none of the folders (1, 3, 5)"));
  r = runMinimanip("merge --out " + out + " " + s0 + " " + s1 + " " + s1);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.out, ::testing::HasSubstr("is also in"));
  r = runMinimanip("merge --out " + out + " " + s0 + " " + other);
  EXPECT_EQ(r.code, 2);
  EXPECT_THAT(r.out, ::testing::HasSubstr("objects.count_max is 3 in " + s0 + ", 2 here"));
  EXPECT_FALSE(fs::exists(out));
  r = runMinimanip("merge --out " + out + " " + s0 + " " + s1);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(readTrials(out).size(), 6u);
}

}  // namespace
}  // namespace mm
