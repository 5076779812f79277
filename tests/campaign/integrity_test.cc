// A campaign's results folder cannot be corrupted: one supervisor at a time (a second refuses,
// naming the first; a lock a killed one left is taken over); input is checked where it enters
// (UTF-8, duplicate keys, a section given a value) before anything is written; a folder that cannot
// be written (disk full, read-only, permission denied) is exit 3 naming the path and the cause,
// leaves no temporary file and resumes to the uninterrupted result once mended; a resume with
// nothing to do writes nothing; records count a failed spawn as such and name the renderer.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <thread>

#include "cli_helpers.h"
#include "../sanitized.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ::testing::HasSubstr;
using namespace testing_cli;

const std::string kMock = "run experiments/quickstart.yaml --set hardware=mock --set progress=none --seed 7";

pid_t start(const std::string& args, const fs::path& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string cmd = "exec " + std::string(MINIMANIP_BINARY) + " " + args + " >'" + log.string() + "' 2>&1";
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

void expectSameTrials(const fs::path& a_dir, const fs::path& b_dir, size_t n) {
  const auto a = readTrials(a_dir), b = readTrials(b_dir);
  ASSERT_EQ(a.size(), n) << a_dir;
  ASSERT_EQ(b.size(), n) << b_dir;
  for (size_t i = 0; i < n; ++i) EXPECT_EQ(outcomeFields(a[i]), outcomeFields(b[i])) << a_dir << ", trial " << i;
}

std::vector<fs::path> temporaries(const fs::path& dir) {
  std::vector<fs::path> v;
  if (!fs::exists(dir)) return v;
  for (const auto& f : fs::recursive_directory_iterator(dir))
    if (f.path().extension() == ".tmp" || f.path().string().find(".partial") != std::string::npos) v.push_back(f.path());
  return v;
}

// Every file's size, modification time and inode: what "nothing written" leaves unchanged. The
// lock file aside: it names the process running in the folder while one does (a few bytes).
std::map<std::string, std::string> stamps(const fs::path& dir) {
  std::map<std::string, std::string> m;
  for (const auto& f : fs::recursive_directory_iterator(dir)) {
    if (f.path().filename() == ".lock") continue;
    struct stat st {};
    ::stat(f.path().c_str(), &st);
    m[f.path().string()] = std::to_string(st.st_size) + " " + std::to_string(st.st_mtim.tv_sec) + "." +
                           std::to_string(st.st_mtim.tv_nsec) + " " + std::to_string(st.st_ino);
  }
  return m;
}

// ---- one supervisor per folder ---------------------------------------------------------------

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(Integrity, ASecondSupervisorOnTheSameFolderRefusesAndTheFolderStaysExact) {
  TempDir d;
  // Long enough that the first is still running 2 s in: 100 mock trials take about 3.3 s with two
  // workers here; under the sanitizers a trial takes ten times as long.
  const int kTrials = testing_sanitized::sanitizedOr(30, 100);
  const std::string common = kMock + " --trials " + std::to_string(kTrials) + " --jobs 2 --out ";
  ASSERT_EQ(runMinimanip(common + (d.path() / "straight").string()).code, 0);
  int round = 0;
  for (const int delay_ms : {100, 500, 1000, 2000}) {
    const fs::path out = d.path() / ("out" + std::to_string(delay_ms));
    const fs::path log1 = d.path() / "first.log", log2 = d.path() / "second.log";
    const pid_t first = start(common + out.string(), log1);
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    ASSERT_EQ(waitpid(first, nullptr, WNOHANG), 0) << "the first supervisor ended before the second started (" << delay_ms << " ms)";
    const pid_t second = start(common + out.string(), log2);
    int status2 = 0;
    waitpid(second, &status2, 0);
    const int code2 = WIFEXITED(status2) ? WEXITSTATUS(status2) : -1;
    // The second refuses at once, naming the first: each takes its claim as it starts, before its
    // input is checked (0.3 s under the sanitizers, a few ms otherwise). Only at 0.1 s apart on a
    // loaded machine may the second reach it first; then the first refuses, naming the second.
    if (delay_ms == 100 && code2 == 0) {
      int status1 = 0;
      waitpid(first, &status1, 0);
      EXPECT_TRUE(WIFEXITED(status1) && WEXITSTATUS(status1) == 2) << slurp(log1);
      EXPECT_THAT(slurp(log1), HasSubstr(out.string() + ": in use by another process (pid " + std::to_string(second)));
      expectSameTrials(out, d.path() / "straight", kTrials);
      ++round;
      continue;
    }
    EXPECT_EQ(code2, 2) << delay_ms << " ms: " << slurp(log2);
    EXPECT_THAT(slurp(log2), HasSubstr(out.string() + ": in use by another process (pid " + std::to_string(first)));
    if (round++ % 2 == 0) {
      // The first goes on undisturbed: every trial once.
      int status = 0;
      waitpid(first, &status, 0);
      EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the first supervisor failed (" << delay_ms << " ms): " << slurp(log1);
    } else {
      // The first is killed with its lock: the next takes it over, says so, and resumes.
      kill(first, SIGKILL);
      waitpid(first, nullptr, 0);
      const RunResult resumed = runMinimanip(common + out.string() + " --set progress=lines");
      ASSERT_EQ(resumed.code, 0) << resumed.out;
      EXPECT_THAT(resumed.out, HasSubstr("took over " + (out / ".lock").string() + " from pid " + std::to_string(first)));
      EXPECT_THAT(resumed.out, HasSubstr("no longer running"));
    }
    expectSameTrials(out, d.path() / "straight", kTrials);
    const json s = json::parse(std::ifstream(out / "summary.json"));
    EXPECT_EQ(s["trials"], kTrials) << delay_ms << " ms";
  }
}

// ---- input at the boundary --------------------------------------------------------------------

class Boundary : public ::testing::Test {
 protected:
  void expectRejected(const std::string& args, const std::string& out, const std::string& message) {
    const RunResult r = runMinimanip(args + " --out '" + out + "'");
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_THAT(r.out, HasSubstr(message));
    EXPECT_THAT(r.out, ::testing::Not(HasSubstr("internal error")));
    EXPECT_FALSE(fs::exists(out)) << "a rejected run must not leave a results folder";
  }
  std::string experiment(const std::string& body) {
    return dir_.file("exp.yaml", "robot: " + (fs::current_path() / "robots/panda/panda.yaml").string() + "\nscene: " +
                                     (fs::current_path() / "scenes/bin_table.xml").string() + "\n" + body);
  }
  TempDir dir_;
};

TEST_F(Boundary, BytesThatAreNotUtf8AreNamedWhereTheyEnter) {
  const std::string out = (dir_.path() / "out").string();
  // In a file's value (Latin-1 e-acute), with the file, line, column and key.
  expectRejected("run " + experiment("name: caf\xe9\ntrials: 2\n"), out, "exp.yaml:3:10: the line of 'name' is not valid UTF-8 (byte 0xE9");
  // In a --set value and in the --out path.
  expectRejected("run experiments/quickstart.yaml --trials 1 --set 'name=r\xe9sult'", out, "--set: 'name=r\\xE9sult' is not valid UTF-8");
  const std::string latin1_out = (dir_.path() / "caf\xe9").string();
  expectRejected("run experiments/quickstart.yaml --trials 1", latin1_out, "--out: '" + dir_.path().string() + "/caf\\xE9' is not valid UTF-8");
  // In a file the experiment names (a tree).
  const std::string tree = dir_.file("tree.xml", "<root BTCPP_format=\"4\">\n  <!-- d\xe9j\xe0 -->\n</root>\n");
  expectRejected("run experiments/quickstart.yaml --trials 1 --set tree=" + tree, out, "tree.xml:2:9: not valid UTF-8 (byte 0xE9");
}

TEST_F(Boundary, ADuplicateKeyAndASectionGivenAValueAreInputErrors) {
  const std::string out = (dir_.path() / "out").string();
  expectRejected("run " + experiment("trials: 2\nobjects:\n  count_min: 1\n  count_max: 2\n  count_min: 2\n"), out,
                 "exp.yaml:7:3: duplicate key 'objects.count_min' (first at line 5");
  expectRejected("run " + experiment("trials: 2\ntrials: 3\n"), out, "exp.yaml:4:1: duplicate key 'trials' (first at line 3");
  expectRejected("run " + experiment("objects: 5\n"), out, "exp.yaml:3:1: 'objects' is a section (objects.count_min, objects.count_max");
}

// A path given with --set is the working directory's, the object catalogue's too (it was taken
// from the project root); the mesh files a catalogue names are its own directory's.
TEST_F(Boundary, ACatalogueGivenWithSetIsFoundFromTheWorkingDirectory) {
  fs::copy_file("scenes/objects.yaml", dir_.path() / "my_objects.yaml");
  fs::copy("scenes/meshes", dir_.path() / "meshes");
  std::string out;
  const int code = shellOut("cd '" + dir_.path().string() + "' && " + std::string(MINIMANIP_BINARY) + " run " +
                                (fs::current_path() / "experiments/quickstart.yaml").string() +
                                " --trials 1 --set hardware=mock --set progress=none --set objects.catalogue=my_objects.yaml --out run 2>&1",
                            out);
  EXPECT_EQ(code, 0) << out;
  EXPECT_TRUE(fs::exists(dir_.path() / "run" / "summary.json")) << out;
}

// ---- output that cannot be written -----------------------------------------------------------

// A file system of our own for a test: a tmpfs of `size` (root's mount); false where this machine
// does not allow it (then the test skips, but fails under CI, where every test must run).
class Mounted {
 public:
  Mounted(const fs::path& dir, const std::string& options) : dir_(dir) {
    fs::create_directories(dir);
    ok_ = ::geteuid() == 0 && std::system(("mount -t tmpfs -o " + options + " tmpfs '" + dir.string() + "' 2>/dev/null").c_str()) == 0;
  }
  ~Mounted() {
    if (ok_) (void)!std::system(("umount -l '" + dir_.string() + "'").c_str());
  }
  bool ok() const { return ok_; }

 private:
  fs::path dir_;
  bool ok_ = false;
};

#define SKIP_OR_FAIL_WITHOUT(cond, what)                                                          \
  do {                                                                                            \
    if (!(cond)) {                                                                                \
      if (std::getenv("MINIMANIP_CI")) FAIL() << what << " is needed and not possible here";       \
      GTEST_SKIP() << what << " is not possible here";                                            \
    }                                                                                             \
  } while (0)

TEST(Integrity, AFullDiskIsExitThreeNamingThePathAndResumesOnceThereIsRoom) {
  TempDir d;
  const Mounted disk(d.path() / "disk", "size=256k");
  SKIP_OR_FAIL_WITHOUT(disk.ok(), "a tmpfs mount (root)");
  const std::string args = kMock + " --trials 30 --jobs 2 --set bt.log=all --out ";
  const fs::path out = d.path() / "disk" / "out";
  RunResult r = runMinimanip(args + out.string());
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_THAT(r.out, ::testing::MatchesRegex("(.|\n)*error: cannot write " + d.path().string() + "/disk/out/[a-z_/0-9.]+: No space left on device(.|\n)*"));
  EXPECT_THAT(r.out, ::testing::Not(HasSubstr("internal error")));
  EXPECT_EQ(temporaries(out), std::vector<fs::path>{});
  const long recorded = static_cast<long>(readTrials(out).size());
  EXPECT_GT(recorded, 0);
  EXPECT_LT(recorded, 30);
  // Room again: the same command resumes to the uninterrupted result.
  ASSERT_EQ(std::system(("mount -o remount,size=64m '" + (d.path() / "disk").string() + "'").c_str()), 0);
  r = runMinimanip(args + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  ASSERT_EQ(runMinimanip(args + (d.path() / "straight").string()).code, 0);
  expectSameTrials(out, d.path() / "straight", 30);
  for (const json& t : readTrials(out)) EXPECT_TRUE(fs::exists(out / t["bt_log"].get<std::string>())) << t["bt_log"];

  // A resume that must rewrite trials.jsonl (a half-written last line) on a disk with no room for
  // the copy: exit 3, the file as it was, no temporary left. Then, with room, it completes.
  std::ofstream(out / "trials.jsonl", std::ios::app) << "{\"schema\":4,\"trial\":30,\"se";
  std::ifstream in(out / "trials.jsonl", std::ios::binary);
  const std::string before((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(std::system(("dd if=/dev/zero of='" + (d.path() / "disk" / "filler").string() + "' bs=64k 2>/dev/null; true").c_str()), 0);
  r = runMinimanip(kMock + " --trials 31 --jobs 2 --set bt.log=all --out " + out.string());
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_THAT(r.out, HasSubstr("No space left on device"));
  EXPECT_EQ(temporaries(out), std::vector<fs::path>{});
  std::ifstream again(out / "trials.jsonl", std::ios::binary);
  EXPECT_EQ(std::string((std::istreambuf_iterator<char>(again)), std::istreambuf_iterator<char>()), before);
  fs::remove(d.path() / "disk" / "filler");
  r = runMinimanip(kMock + " --trials 31 --jobs 2 --set bt.log=all --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(readTrials(out).size(), 31u);
}

TEST(Integrity, AReadOnlyFolderResumesWithNothingToDoAndRefusesMoreWithExitThree) {
  TempDir d;
  const Mounted disk(d.path() / "disk", "size=16m");
  SKIP_OR_FAIL_WITHOUT(disk.ok(), "a tmpfs mount (root)");
  const fs::path out = d.path() / "disk" / "out";
  const std::string args = kMock + " --trials 4 --jobs 2 --out " + out.string();
  ASSERT_EQ(runMinimanip(args).code, 0);
  // Nothing to do writes nothing, not even on a writable folder.
  const auto before = stamps(out);
  RunResult r = runMinimanip(args);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("Trials:            4"));
  EXPECT_EQ(stamps(out), before);
  // Read-only: nothing to do is still fine; more trials are exit 3 naming the path and the cause.
  ASSERT_EQ(std::system(("mount -o remount,ro '" + (d.path() / "disk").string() + "'").c_str()), 0);
  r = runMinimanip(args);
  EXPECT_EQ(r.code, 0) << r.out;
  r = runMinimanip(kMock + " --trials 6 --jobs 2 --out " + out.string());
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_THAT(r.out, HasSubstr("cannot write " + out.string() + "/"));
  EXPECT_THAT(r.out, HasSubstr(": Read-only file system"));
  ASSERT_EQ(std::system(("mount -o remount,rw '" + (d.path() / "disk").string() + "'").c_str()), 0);
  EXPECT_EQ(stamps(out), before);
}

TEST(Integrity, AFolderThatMayNotBeWrittenIsExitThreeNamingIt) {
  TempDir d;
  // As an unprivileged user (root writes anywhere): setpriv from util-linux.
  const bool can = ::geteuid() == 0 && std::system("command -v setpriv >/dev/null") == 0;
  SKIP_OR_FAIL_WITHOUT(can, "running as another user (setpriv, root)");
  // The unprivileged user reads the experiment, robot and scene from this checkout.
  if (std::system(("setpriv --reuid=65534 --regid=65534 --clear-groups test -r '" + (fs::current_path() / "experiments/quickstart.yaml").string() +
                   "' 2>/dev/null").c_str()) != 0)
    GTEST_SKIP() << "this checkout is not readable by other users (" << fs::current_path() << "): nothing to try as one";
  fs::permissions(d.path(), fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read |
                                fs::perms::others_exec);
  const fs::path out = d.path() / "out";
  std::string text;
  const int code = shellOut("setpriv --reuid=65534 --regid=65534 --clear-groups " + std::string(MINIMANIP_BINARY) + " " + kMock +
                                " --trials 1 --out " + out.string() + " 2>&1",
                            text);
  EXPECT_EQ(code, 3) << text;
  EXPECT_THAT(text, HasSubstr("error: cannot write " + out.string() + ": Permission denied"));
  EXPECT_FALSE(fs::exists(out));
  // A file it may not read is bad input (exit 2) naming the file, not an internal error.
  const std::string tree = d.file("tree.xml", "<root BTCPP_format=\"4\"/>\n");
  fs::permissions(tree, fs::perms::owner_read | fs::perms::owner_write);
  const int unreadable = shellOut("setpriv --reuid=65534 --regid=65534 --clear-groups " + std::string(MINIMANIP_BINARY) + " " + kMock +
                                      " --trials 1 --set tree=" + tree + " --out " + (d.path() / "out2").string() + " 2>&1",
                                  text);
  EXPECT_EQ(unreadable, 2) << text;
  EXPECT_THAT(text, HasSubstr(tree + ": cannot be read: Permission denied"));
}

// A closed-form IK declared for an arm it does not fit is bad input: exit 2 naming the robot's
// file before any trial (it was a worker crash in every trial, and exit 0).
TEST(Integrity, AClosedFormIkThatDoesNotFitTheArmIsExitTwoBeforeAnyTrial) {
  TempDir d;
  std::string arm = slurp("robots/ur5e/ur5e.yaml");
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"analytic_ik: ur ", "analytic_ik: panda "},
                                 {"gripper: ../grippers/", "gripper: " + (fs::current_path() / "robots/grippers/").string()}}) {
    const auto pos = arm.find(from);
    ASSERT_NE(pos, std::string::npos) << from;
    arm.replace(pos, from.size(), to);
  }
  const std::string robot = d.file("arm.yaml", arm);
  const RunResult r = runMinimanip("run experiments/ur5e_quickstart.yaml --trials 2 --set progress=none --set robot=" + robot +
                                   " --out " + (d.path() / "out").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_THAT(r.out, HasSubstr(robot + ": the analytic IK needs a Panda-shaped"));
  EXPECT_FALSE(fs::exists(d.path() / "out" / "trials.jsonl"));
}

// ---- records -----------------------------------------------------------------------------------

TEST(Integrity, AFailedSpawnIsCountedAsSuchNeverAsAnEmptiedBin) {
  TempDir d;
  // Eight cubes 0.3 m apart do not fit in the bin: every spawn fails.
  const fs::path out = d.path() / "out";
  const RunResult r = runMinimanip("run experiments/quickstart.yaml --trials 3 --set progress=none --set objects.count_min=8 "
                                   "--set objects.count_max=8 --set objects.min_spacing=0.3 --set task.goal=clear_bin --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("Bins emptied:      0 of 3"));
  EXPECT_THAT(r.out, HasSubstr("Objects placed:    0 of 0 (0 left in bins; 3 spawns failed)"));
  for (const json& t : readTrials(out)) {
    EXPECT_EQ(t["failure_kind"], "spawn");
    EXPECT_EQ(t["failure_stage"], "spawn");
    EXPECT_EQ(t["objects_in_bin"], 0);
  }
  const json s = json::parse(std::ifstream(out / "summary.json"));
  EXPECT_EQ(s["spawn_failures"], 3);
  EXPECT_EQ(s["bins_cleared"], 0);
  EXPECT_EQ(s["objects_spawned"], 0);
}

TEST(Integrity, ACameraModeCampaignRecordsItsRenderer) {
  TempDir d;
  const fs::path out = d.path() / "out";
  const RunResult r = runMinimanip("run experiments/camera.yaml --trials 1 --set progress=none --out " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const json s = json::parse(std::ifstream(out / "summary.json"));
  ASSERT_TRUE(s["environment"]["renderer"].is_string()) << s["environment"].dump();
  EXPECT_THAT(s["environment"]["renderer"].get<std::string>(), ::testing::Not(HasSubstr("none")));
}

}  // namespace
}  // namespace mm
