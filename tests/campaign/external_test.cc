// External components over the process protocol: the reference client (tools/external_grasps.py,
// Debian's python3 and NumPy) asked directly on a synthetic view and through whole campaigns; a
// client that crashes, hangs, answers garbage or in another frame is a recorded failure of that
// perception and a fresh client answers the next; bad configuration is exit 2 before any trial.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "campaign/record.h"
#include "cli_helpers.h"
#include "core/camera.h"
#include "task/external_component.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

const char* kClient = "/usr/bin/python3 tools/external_grasps.py";

// A camera 0.8 m over the bin's floor looking straight down at a 4 x 4 x 5 cm box at the centre.
Frame boxSeenFromAbove() {
  Frame f;
  CameraModel& c = f.camera;
  c.width = 160, c.height = 120, c.fx = c.fy = 200, c.cx = (c.width - 1) / 2.0, c.cy = (c.height - 1) / 2.0;
  c.T_world_camera = makePose(Vec3(0, 0, 0.8), Vec3(1, -1, -1).asDiagonal().toDenseMatrix());
  f.depth.assign(static_cast<size_t>(c.width) * c.height, 0.8f);
  for (int v = 0; v < c.height; ++v)
    for (int u = 0; u < c.width; ++u) {
      const Vec3 p = c.unproject(u, v, 0.75);  // at the box's top's depth
      if (std::abs(p.x()) <= 0.02 && std::abs(p.y()) <= 0.02) f.depth[static_cast<size_t>(v) * c.width + u] = 0.75f;
    }
  return f;
}

ExternalRequest requestFor(const Frame& f) {
  ExternalRequest r;
  r.camera = f.camera;
  r.region_half = Vec3(0.15, 0.15, 0.14);
  r.gripper.stroke = 0.08;
  return r;
}

ExternalOptions client(const std::string& args = "", double timeout = 30) {
  ExternalOptions o;
  o.command = std::string(kClient) + " " + args;
  o.cwd = MINIMANIP_SOURCE_DIR;
  o.timeout = timeout;
  return o;
}

TEST(External, TheReferenceClientGraspsABoxAcrossItsWidthFromAbove) {
  testing_cli::TempDir dir;
  const Frame f = boxSeenFromAbove();
  for (const char* frame : {"camera", "world"}) {
    ExternalOptions o = client(std::string("--frame ") + frame);
    o.frame = frame;
    ExternalComponent x(o, dir.path() / "stderr.log");
    ExternalRequest r = requestFor(f);
    const ExternalCall c = x.call(r, f);
    ASSERT_TRUE(c.ok()) << c.result << ": " << c.reason;
    ASSERT_FALSE(c.answer.grasps.empty());
    const ExternalGrasp& g = c.answer.grasps.front();
    // In the world, whichever frame it answered in: over the box, pointing down, closing across
    // its 4 cm (plus the client's 12 mm each side), its fingertips below the top.
    EXPECT_LT(g.T_world_tcp.translation().head<2>().norm(), 0.006) << frame;
    EXPECT_NEAR(g.T_world_tcp.linear().col(2).z(), -1.0, 1e-6);
    EXPECT_NEAR(g.opening, 0.04 + 0.024, 0.006);
    const double tips = g.T_world_tcp.translation().z() - r.gripper.pad_z_max;
    EXPECT_LT(tips, 0.05);
    EXPECT_GT(tips, 0.02);
    EXPECT_EQ(x.starts(), 1);
  }
  std::ifstream log(dir.path() / "stderr.log");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("external_grasps: request 1:"), std::string::npos) << "its stderr goes to the log: " << text;
}

TEST(External, EachMisbehaviourIsAValueAndAFreshClientAnswersNext) {
  testing_cli::TempDir dir;
  const Frame f = boxSeenFromAbove();
  struct Case {
    const char* misbehave;
    const char* result;
    const char* says;
  };
  for (const Case& k : {Case{"crash", "crash", "signal 6 (SIGABRT)"}, Case{"hang", "timeout", "within external.timeout (1 s)"},
                        Case{"garbage", "not_protocol", "not JSON"}, Case{"wrong-frame", "not_protocol", "in the world frame"},
                        Case{"error", "error", "asked to fail"}}) {
    // Every second request (ids 2, 4, ...) misbehaves: 1 answers, 2 does not, 3 answers again.
    // Only the hang waits for the cap, so only it has a short one: a crash is seen when the child's
    // pipe closes, which on a loaded machine (the sanitized pass) may take longer than a second.
    const double cap = std::string(k.misbehave) == "hang" ? 1.0 : 30.0;
    ExternalComponent x(client(std::string("--misbehave ") + k.misbehave + " --every 2", cap), dir.path() / "stderr.log");
    for (int call = 1; call <= 3; ++call) {
      ExternalRequest r = requestFor(f);
      const ExternalCall c = x.call(r, f);
      EXPECT_EQ(r.id, static_cast<uint64_t>(call));
      if (call == 2) {
        EXPECT_EQ(c.result, k.result) << k.misbehave << ": " << c.reason;
        EXPECT_NE(c.reason.find(k.says), std::string::npos) << k.misbehave << ": " << c.reason;
        EXPECT_TRUE(c.answer.grasps.empty());
      } else {
        EXPECT_TRUE(c.ok()) << k.misbehave << " call " << call << ": " << c.reason;
      }
    }
    // The client that did not answer was ended and another started (its own error keeps it).
    EXPECT_EQ(x.starts(), std::string(k.misbehave) == "error" ? 1 : 2) << k.misbehave;
  }
  ExternalOptions none;
  none.command = "no_such_external_detector --x";
  ExternalComponent x(none, dir.path() / "stderr.log");
  ExternalRequest r = requestFor(f);
  const ExternalCall c = x.call(r, f);
  EXPECT_EQ(c.result, "cannot_start");
  EXPECT_NE(c.reason.find("no such program in PATH"), std::string::npos) << c.reason;
}

// A short round of the external detector's experiment (fewer objects): its campaign folder.
testing_cli::RunResult runExternal(const std::string& out, const std::string& sets) {
  return testing_cli::runMinimanip("run experiments/external_detector.yaml --trials 1 --jobs 1 --set progress=none "
                                   "--set objects.count_min=3 --set objects.count_max=3 " + sets + " --out " + out);
}

TEST(External, ImagesLeftByAKilledWorkerAreRemovedByTheNextComponent) {
  const fs::path shm = "/dev/shm";
  if (!fs::is_directory(shm) || access(shm.c_str(), W_OK) != 0) GTEST_SKIP() << "no writable /dev/shm here";
  // A worker killed by SIGKILL runs no destructor: its folder stays, named by a pid now gone.
  const pid_t gone = fork();
  if (gone == 0) _exit(0);
  ASSERT_GT(gone, 0);
  waitpid(gone, nullptr, 0);
  const fs::path orphan = shm / ("minimanip-external-" + std::to_string(gone) + "-test01");
  const fs::path running = shm / ("minimanip-external-" + std::to_string(getpid()) + "-test02");
  for (const fs::path& d : {orphan, running}) {
    fs::create_directories(d);
    std::ofstream(d / "depth.npy") << "left";
  }
  testing_cli::TempDir dir;
  const Frame f = boxSeenFromAbove();
  {
    ExternalComponent c(client(), dir.path() / "stderr.log");
    ExternalRequest req = requestFor(f);
    EXPECT_TRUE(c.call(req, f).ok());
    EXPECT_FALSE(fs::exists(orphan)) << "a folder of a process that ended is removed";
    EXPECT_TRUE(fs::exists(running)) << "a running process's folder is left";
    EXPECT_TRUE(fs::exists(req.depth));
    EXPECT_EQ(req.depth.parent_path().filename().string().rfind("minimanip-external-" + std::to_string(getpid()) + "-", 0), 0u);
  }
  fs::remove_all(running);
}

TEST(External, ACampaignPicksWithTheReferenceClientsGrasps) {
  testing_cli::TempDir dir;
  const std::string out = (dir.path() / "run").string();
  const auto r = runExternal(out, "");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = testing_cli::readTrials(out);
  ASSERT_EQ(trials.size(), 1u);
  const TrialRecord t = fromJsonLine(trials[0].dump(), "trials.jsonl");
  ASSERT_FALSE(t.o.external_calls.empty());
  for (const ExternalCallRecord& c : t.o.external_calls) {
    EXPECT_EQ(c.result, "answer") << c.reason;
    EXPECT_GT(c.answer_seconds, 0);
  }
  int in_tray = 0;
  for (const GraspAttempt& a : t.o.grasp_attempts) in_tray += a.success();
  EXPECT_GE(in_tray, 1) << "the client's grasps place objects";
  for (const PickRecord& p : t.o.picks) EXPECT_EQ(p.grasp_type, "external") << "the record says which component proposed it";
  EXPECT_TRUE(fs::exists(fs::path(out) / "external_stderr.log"));
}

TEST(External, ACrashingAHangingAndALyingClientEachLeaveACompleteCampaign) {
  testing_cli::TempDir dir;
  struct Case {
    const char* misbehave;
    const char* result;
  };
  for (const Case& k : {Case{"crash", "crash"}, Case{"hang", "timeout"}, Case{"garbage", "not_protocol"}}) {
    const std::string out = (dir.path() / k.misbehave).string();
    const auto r = runExternal(out, std::string("--set 'external.command=") + kClient + " --misbehave " + k.misbehave +
                                        " --every 2' --set external.timeout=2");
    ASSERT_EQ(r.code, 0) << k.misbehave << ": " << r.out;
    const auto trials = testing_cli::readTrials(out);
    ASSERT_EQ(trials.size(), 1u) << k.misbehave;
    EXPECT_TRUE(fs::exists(fs::path(out) / "summary.json"));
    const TrialRecord t = fromJsonLine(trials[0].dump(), "trials.jsonl");
    int bad = 0, good = 0;
    for (const ExternalCallRecord& c : t.o.external_calls) {
      if (c.result == "answer") {
        ++good;
      } else {
        ++bad;
        EXPECT_EQ(c.result, k.result) << c.reason;
      }
    }
    EXPECT_GE(bad, 1) << k.misbehave << ": the second request failed as it does";
    EXPECT_GE(good, 1) << k.misbehave << ": the first was answered, and the fresh client's";
    // Each call that did not answer is the failure of that perception, recorded with its reason.
    int recorded = 0;
    for (const RecordedFailure& f : t.o.failures)
      recorded += f.failure.stage == "external_grasps" && f.failure.kind == FailureKind::kPerception &&
                  f.failure.reason.find("external component") != std::string::npos;
    EXPECT_EQ(recorded, bad) << k.misbehave;
  }
}

TEST(External, ATrialRendersAgainFromItsRecordedAnswersWithoutTheClient) {
  // The client is a copy that is gone by the time of the replay: had the replay started it, its
  // calls would have crashed and the outcome differed.
  testing_cli::TempDir dir;
  const fs::path copy = dir.path() / "client.py";
  fs::copy_file(fs::path(MINIMANIP_SOURCE_DIR) / "tools/external_grasps.py", copy);
  const std::string out = (dir.path() / "run").string();
  const auto r = runExternal(out, "--set 'external.command=/usr/bin/python3 " + copy.string() + " --misbehave crash --every 3'");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto trials = testing_cli::readTrials(out);
  ASSERT_EQ(trials.size(), 1u);
  const TrialRecord t = fromJsonLine(trials[0].dump(), "trials.jsonl");
  int answers = 0, crashes = 0;
  for (const ExternalCallRecord& c : t.o.external_calls) {
    if (c.result == "answer") {
      ++answers;
      EXPECT_NE(c.answer.find("\"grasps\""), std::string::npos) << "the answer line is kept as it came: " << c.answer;
    } else {
      ++crashes;
      EXPECT_EQ(c.result, "crash") << c.reason;
      EXPECT_TRUE(c.answer.empty());
    }
  }
  ASSERT_GE(answers, 2);
  ASSERT_GE(crashes, 1);
  fs::remove(copy);
  const auto replay = testing_cli::runMinimanip("render " + out + " --trial 0 --set render.keyframes=end --set render.video=false");
  ASSERT_EQ(replay.code, 0) << replay.out;
  EXPECT_NE(replay.out.find("Replay matches trial 0"), std::string::npos) << replay.out;
}

TEST(External, BadConfigurationIsExitTwoBeforeAnyTrial) {
  testing_cli::TempDir dir;
  struct Case {
    std::string set, says;
  };
  for (const Case& k : {Case{"external.command=none", "external.command is none: expected the command"},
                        Case{"external.command=", "'external.command' expects a string"}, Case{"external.frame=gripper", "external.frame"},
                        Case{"external.command=no_such_external_detector", "no such program in PATH"},
                        Case{"external.cwd=" + (dir.path() / "nowhere").string(), "is not a folder"}}) {
    const std::string out = (dir.path() / "run").string();
    const auto r = testing_cli::runMinimanip("run experiments/external_detector.yaml --trials 1 --set progress=none --set '" + k.set +
                                             "' --out " + out);
    EXPECT_EQ(r.code, 2) << k.set << ": " << r.out;
    EXPECT_NE(r.out.find(k.says), std::string::npos) << k.set << ": " << r.out;
    EXPECT_FALSE(fs::exists(fs::path(out) / "trials.jsonl")) << k.set;
  }
  // The segmentation given to a component nothing asks would mark every record an oracle run.
  const auto r = testing_cli::runMinimanip("run experiments/clutter_pile.yaml --trials 1 --set progress=none --set external.oracle=true --out " +
                                           (dir.path() / "oracle").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--set external.oracle"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("nothing asks the component"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace mm
