// Campaigns as worker processes: a trial that segfaults or hangs is recorded and the campaign goes
// on; a campaign killed at any moment (the supervisor or a worker, kill -9) and resumed equals an
// uninterrupted one; a results folder of another configuration is refused.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <random>
#include <thread>

#include "cli_helpers.h"
#include "../sanitized.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;
using namespace testing_cli;

const std::string kMock = "run experiments/quickstart.yaml --set hardware=mock --set progress=none --seed 5";

TEST(Workers, ASegfaultAndAHangAreRecordedAndEveryOtherTrialRuns) {
  TempDir d;
  const RunResult r = runMinimanip(kMock + " --trials 8 --jobs 2 --set test_faults.segfault=2 --set test_faults.segfault_once=4 "
                                           "--set test_faults.hang=5 --set watchdog=5 --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto t = readTrials(d.path() / "out");
  ASSERT_EQ(t.size(), 8u);
  for (const json& j : t) {
    const int trial = j["trial"];
    if (trial == 2) {
      EXPECT_EQ(j["failure_kind"], "crash");
      EXPECT_EQ(j["tree_status"], "CRASH");
      EXPECT_EQ(j["attempts"], 2);
      EXPECT_THAT(j["failure_reason"].get<std::string>(), HasSubstr("seed 5, trial 2"));
    } else if (trial == 5) {
      EXPECT_EQ(j["failure_kind"], "hang");
      EXPECT_EQ(j["attempts"], 2);
      EXPECT_THAT(j["failure_reason"].get<std::string>(), HasSubstr("watchdog"));
    } else {
      EXPECT_TRUE(j["success"].get<bool>()) << j.dump();
      EXPECT_EQ(j["attempts"], trial == 4 ? 2 : 1) << "trial " << trial;
    }
  }
  const json s = json::parse(std::ifstream(d.path() / "out" / "summary.json"));
  EXPECT_EQ(s["crashes"], 1);
  EXPECT_EQ(s["hangs"], 1);
  EXPECT_EQ(s["successes"], 6);
  // The trial retried after its worker died is the trial an undisturbed worker runs.
  ASSERT_EQ(runMinimanip(kMock + " --trials 8 --only 4 --out " + (d.path() / "alone").string()).code, 0);
  EXPECT_EQ(outcomeFields(readTrials(d.path() / "alone")[0]), outcomeFields(t[4]));
}

TEST(Resume, ExtendsACampaignAndDropsAHalfWrittenLine) {
  TempDir d;
  const std::string out = (d.path() / "out").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 4 --out " + out).code, 0);
  {  // the supervisor died in the middle of a line
    std::ofstream(fs::path(out) / "trials.jsonl", std::ios::app) << "{\"schema\":4,\"trial\":4,\"seed";
  }
  const RunResult r = runMinimanip(kMock + " --trials 7 --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_EQ(runMinimanip(kMock + " --trials 7 --out " + (d.path() / "straight").string()).code, 0);
  const auto a = readTrials(out), b = readTrials(d.path() / "straight");
  ASSERT_EQ(a.size(), 7u);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(outcomeFields(a[i]), outcomeFields(b[i])) << "trial " << i;
  const json s = json::parse(std::ifstream(fs::path(out) / "summary.json"));
  EXPECT_EQ(s["trials"], 7);
}

TEST(Resume, AnotherConfigurationIsRefusedNamingWhatDiffers) {
  TempDir d;
  const std::string out = (d.path() / "out").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 2 --out " + out).code, 0);
  const std::string before = json::parse(std::ifstream(fs::path(out) / "summary.json")).dump();
  RunResult r = runMinimanip(kMock + " --trials 2 --set objects.count_max=2 --out " + out);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("objects.count_max is 3 there, 2 here"));
  // A tree file with other contents at the same path is another configuration too.
  const std::string tree = d.file("tree.xml", "");
  fs::copy_file("experiments/trees/mini_manip.xml", tree, fs::copy_options::overwrite_existing);
  const std::string out2 = (d.path() / "out2").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 2 --set tree=" + tree + " --out " + out2).code, 0);
  std::ofstream(tree, std::ios::app) << "\n<!-- edited -->\n";
  r = runMinimanip(kMock + " --trials 2 --set tree=" + tree + " --out " + out2);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr("tree file contents differ"));
  EXPECT_EQ(json::parse(std::ifstream(fs::path(out) / "summary.json")).dump(), before) << "a refused run must not touch the results";
}

// A resume runs again only what this run asks for: crashed trials outside --only stay recorded (and
// a crashed trial's unknown bin is not counted as emptied); --only lists a trial once however
// often it is named; a shard's folder is not resumed as another shard.
TEST(Resume, RunsAgainOnlyWhatItIsAskedFor) {
  TempDir d;
  const std::string out = (d.path() / "out").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 3 --set test_faults.segfault=1 --out " + out).code, 0);
  json s = json::parse(std::ifstream(fs::path(out) / "summary.json"));
  EXPECT_EQ(s["crashes"], 1);
  const auto first = readTrials(out);
  EXPECT_EQ(s["bins_cleared"].get<long>(), static_cast<long>(std::count_if(first.begin(), first.end(), [](const json& t) {
              return t["objects_left_in_bin"] == 0 && t["failure_kind"] != "crash";
            })));
  ASSERT_EQ(runMinimanip(kMock + " --trials 3 --set test_faults.segfault=1 --only 0,0 --out " + out).code, 0);
  auto t = readTrials(out);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[1]["failure_kind"], "crash");
  s = json::parse(std::ifstream(fs::path(out) / "summary.json"));
  EXPECT_EQ(s["trials"], 3);
  const RunResult other = runMinimanip(kMock + " --trials 3 --set test_faults.segfault=1 --shard 1/2 --out " + out);
  EXPECT_EQ(other.code, 2) << other.out;
  EXPECT_THAT(other.out, HasSubstr("shard 0/1 of the campaign, this run is shard 1/2"));
  const std::string dup = (d.path() / "dup").string();
  ASSERT_EQ(runMinimanip(kMock + " --trials 3 --only 1,1 --jobs 2 --out " + dup).code, 0);
  EXPECT_EQ(readTrials(dup).size(), 1u);
}

pid_t startMinimanip(const std::string& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string cmd = "exec " + std::string(MINIMANIP_BINARY) + " " + args + " >/dev/null 2>&1";
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

std::vector<pid_t> childrenOf(pid_t pid) {
  std::vector<pid_t> v;
  std::ifstream in("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) + "/children");
  for (pid_t c; in >> c;) v.push_back(c);
  return v;
}

// kill -9 at seeded random moments, of the supervisor or of one of its workers, then resume; again
// and again; then a last resume to the end. The trials equal an uninterrupted run's. The first
// rounds strike while the campaign starts; the others after a random number of further trials
// and a random delay (so they land mid-trial and mid-write whatever the machine's speed).
long linesIn(const fs::path& file) {
  std::ifstream in(file);
  return std::count(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>(), '\n');
}

TEST(Resume, KilledAtRandomMomentsThenResumedEqualsAnUninterruptedRun) {
  TempDir d;
  const std::string out = (d.path() / "out").string();
  const fs::path jsonl = fs::path(out) / "trials.jsonl";
  // Enough trials that every round lands mid-campaign: a mock trial of the quickstart takes about
  // 20 ms with two workers (its 4 s cycle).
  const int kTrials = testing_sanitized::sanitizedOr(36, 60);  // 36 under the sanitizers
  const std::string args = kMock + " --trials " + std::to_string(kTrials) + " --jobs 2 --set bt.log=all --out " + out;
  std::mt19937 rng(2026);
  int supervisor_kills = 0, worker_kills = 0, mid_campaign = 0;
  std::string progress;
  for (int round = 0; round < 8; ++round) {
    const long before = linesIn(jsonl);
    const pid_t pid = startMinimanip(args);
    if (round >= 2) {  // wait for 1..4 more trials (or the end), at most 5 minutes
      const long target = before + std::uniform_int_distribution<int>(1, 4)(rng);
      for (int k = 0; k < 30000 && linesIn(jsonl) < target && waitpid(pid, nullptr, WNOHANG) == 0; ++k)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(0, 100)(rng)));
    const std::vector<pid_t> workers = childrenOf(pid);
    if (!workers.empty() && rng() % 2 == 0) {
      kill(workers[rng() % workers.size()], SIGKILL);
      ++worker_kills;
      std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(0, 200)(rng)));
    }
    kill(pid, SIGKILL);
    ++supervisor_kills;
    waitpid(pid, nullptr, 0);
    const long lines = linesIn(jsonl);
    mid_campaign += lines > 0 && lines < kTrials;
    progress += ' ';
    progress += std::to_string(lines);
  }
  EXPECT_GE(mid_campaign, 3) << "the kills should land while trials run; trials recorded after each:" << progress;
  const RunResult last = runMinimanip(args);
  ASSERT_EQ(last.code, 0) << last.out;
  ASSERT_EQ(runMinimanip(kMock + " --trials " + std::to_string(kTrials) + " --jobs 2 --set bt.log=all --out " + (d.path() / "straight").string()).code, 0);
  const auto a = readTrials(out), b = readTrials(d.path() / "straight");
  ASSERT_EQ(a.size(), static_cast<size_t>(kTrials));
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(outcomeFields(a[i]), outcomeFields(b[i])) << "trial " << i;
  // Every trial's tree log is there, complete, and nothing half-written is left.
  for (const json& t : a) EXPECT_TRUE(fs::exists(fs::path(out) / t["bt_log"].get<std::string>())) << t["bt_log"];
  for (const auto& f : fs::directory_iterator(fs::path(out) / "bt")) EXPECT_NE(f.path().extension(), ".tmp");
  std::printf("[ info ] %d supervisor kills, %d worker kills; trials recorded after each:%s\n", supervisor_kills, worker_kills,
              progress.c_str());
}

}  // namespace
}  // namespace mm
