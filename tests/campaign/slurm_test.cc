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
  const std::string submit = conf + "tools/slurm/submit --wait 3 " + campaign.string();
  struct Stop {  // the cluster is stopped whatever the test's end
    std::string cluster;
    ~Stop() { shell("tools/slurm/local_cluster stop " + cluster); }
  } stop{cluster};
  const int submitted = shell(submit + args, &said);
  ASSERT_EQ(submitted, 0) << said;
  for (int k = 0; k < 3; ++k) EXPECT_EQ(readTrials(campaign / ("shard_" + std::to_string(k))).size(), 3u) << "shard " << k;
  ASSERT_EQ(runMinimanip("run" + args + " --set progress=none --out " + (d.path() / "local").string()).code, 0);
  const auto local = readTrials(d.path() / "local");
  auto expectMergedEqualsLocal = [&] {
    const auto merged = readTrials(campaign / "merged");
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
  };
  expectMergedEqualsLocal();

  // Submitted again, the same: it resumes (nothing left to run) and the merge is made again.
  ASSERT_EQ(shell(submit + args, &said), 0) << said;
  EXPECT_THAT(said, ::testing::HasSubstr("resuming the submission in " + campaign.string()));
  expectMergedEqualsLocal();

  // A shard that fails (its folder's record broken): --wait names it, says the merge never ran,
  // and exits 1.
  std::ofstream(campaign / "shard_1" / "campaign.json") << "{";
  EXPECT_EQ(shell(submit + args, &said), 1) << said;
  EXPECT_THAT(said, ::testing::MatchesRegex("(.|\n)*shard 1 \\(job [0-9]+_1\\) did not succeed: FAILED, exit code 2(.|\n)*"));
  EXPECT_THAT(said, ::testing::HasSubstr("not a campaign record"));  // the shard's own message, from its log
  EXPECT_THAT(said, ::testing::MatchesRegex("(.|\n)*the merge job [0-9]+ never ran(.|\n)*"));
  EXPECT_THAT(said, ::testing::Not(::testing::HasSubstr("shard 0 ")));

  // Other arguments into the same folder are refused before anything is submitted.
  EXPECT_EQ(shell(submit + args + " --trials 12", &said), 2) << said;
  EXPECT_THAT(said, ::testing::HasSubstr(campaign.string() + " holds another submission"));

  // No cluster named: the message says how to name one.
  if (!fs::exists("/etc/slurm/slurm.conf")) {
    EXPECT_EQ(shell("env -u SLURM_CONF tools/slurm/submit 3 " + (d.path() / "other").string() + args, &said), 2) << said;
    EXPECT_THAT(said, ::testing::HasSubstr("export SLURM_CONF="));
  }
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
