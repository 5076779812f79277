// A child process on a line protocol: lines both ways, its working directory and its stderr file as
// asked, a hang seen as a timeout, a crash as the end of its output and the signal it died of, and a
// program that cannot be started refused with its reason before anything runs.
#include "core/child_process.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace mm {
namespace {

namespace fs = std::filesystem;
using testing::HasSubstr;

ChildSpec shell(const std::string& script) { return {{"sh", "-c", script}, {}, {}}; }

fs::path freshDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("mm_child_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string readAll(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(ChildProcess, AnswersLineByLineAndEndsWhenItsInputEnds) {
  ChildProcess c({{"cat"}, {}, {}});  // from PATH
  ASSERT_TRUE(c.running());
  ASSERT_TRUE(c.send("{\"id\": 1}"));
  ASSERT_TRUE(c.send("second line"));
  std::string line;
  ASSERT_EQ(c.readLine(line, 10), ChildProcess::Read::kLine);
  EXPECT_EQ(line, "{\"id\": 1}");
  ASSERT_EQ(c.readLine(line, 10), ChildProcess::Read::kLine);
  EXPECT_EQ(line, "second line");
  c.closeInput();
  EXPECT_EQ(c.readLine(line, 10), ChildProcess::Read::kEnd);
  EXPECT_EQ(c.stop(5), "exited with status 0");
  EXPECT_FALSE(c.running());
}

TEST(ChildProcess, SplitsWhatArrivesInOneReadAndJoinsWhatArrivesInPieces) {
  // Two lines in one write, then one line in three writes with pauses between them.
  ChildProcess c(shell("printf 'a\\nb\\n'; printf 'c'; sleep 0.1; printf 'd'; sleep 0.1; printf 'e\\n'; printf 'half'"));
  std::string line;
  for (const char* want : {"a", "b", "cde"}) {
    ASSERT_EQ(c.readLine(line, 10), ChildProcess::Read::kLine);
    EXPECT_EQ(line, want);
  }
  EXPECT_EQ(c.readLine(line, 10), ChildProcess::Read::kEnd) << "a half line at its end is dropped";
}

TEST(ChildProcess, RunsInItsWorkingDirectoryWithItsStderrInTheLog) {
  const fs::path dir = freshDir("cwd");
  const fs::path log = dir / "child.stderr.log";
  ChildSpec spec = shell("pwd; echo 'a diagnostic' >&2; echo done");
  spec.cwd = dir;
  spec.stderr_file = log;
  ChildProcess c(spec);
  std::string line;
  ASSERT_EQ(c.readLine(line, 10), ChildProcess::Read::kLine);
  EXPECT_EQ(fs::canonical(line), fs::canonical(dir));
  ASSERT_EQ(c.readLine(line, 10), ChildProcess::Read::kLine);
  EXPECT_EQ(line, "done") << "stderr never mixes into the protocol";
  EXPECT_EQ(c.stop(5), "exited with status 0");
  EXPECT_EQ(readAll(log), "a diagnostic\n");
  // A second child appends to the same log.
  ChildProcess again(spec);
  for (int k = 0; k < 2; ++k) ASSERT_EQ(again.readLine(line, 10), ChildProcess::Read::kLine);
  EXPECT_EQ(again.stop(5), "exited with status 0");
  EXPECT_EQ(readAll(log), "a diagnostic\na diagnostic\n");
  // A program named relative to a working directory named relative to ours (a user's
  // `command: ./detector.py` with `cwd: my_detector`).
  std::ofstream(dir / "hello.sh") << "#!/bin/sh\necho hello from \"$(basename \"$PWD\")\"\n";
  fs::permissions(dir / "hello.sh", fs::perms::owner_all);
  ChildProcess script({{"./hello.sh"}, fs::relative(dir), {}});
  ASSERT_EQ(script.readLine(line, 10), ChildProcess::Read::kLine);
  EXPECT_EQ(line, "hello from " + dir.filename().string());
  EXPECT_EQ(script.stop(5), "exited with status 0");
  fs::remove_all(dir);
}

TEST(ChildProcess, AHangIsATimeoutAndStopKillsIt) {
  ChildProcess c(shell("echo started; exec sleep 60"));
  std::string line;
  ASSERT_EQ(c.readLine(line, 10), ChildProcess::Read::kLine);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(c.readLine(line, 0.3), ChildProcess::Read::kTimeout);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(waited, 0.3);
  EXPECT_LT(waited, 5.0);
  EXPECT_TRUE(c.running());
  EXPECT_EQ(c.stop(0.05), "died of signal 9 (SIGKILL)");
  EXPECT_FALSE(c.running());
}

TEST(ChildProcess, ACrashIsTheEndOfItsOutputAndSaysItsSignal) {
  ChildProcess c(shell("ulimit -c 0; read request; kill -SEGV $$"));  // no core file to wait for
  ASSERT_TRUE(c.send("request"));
  std::string line;
  EXPECT_EQ(c.readLine(line, 10), ChildProcess::Read::kEnd);
  EXPECT_EQ(c.stop(5), "died of signal 11 (SIGSEGV)");
}

TEST(ChildProcess, ALineWithNoEndIsCutOffNotKept) {
  // More than kMaxLine bytes with no newline (a progress bar gone wrong): refused once past the cap.
  ChildProcess c(shell("exec head -c 80000000 /dev/zero"));
  std::string line;
  EXPECT_EQ(c.readLine(line, 60), ChildProcess::Read::kTooLong);
  EXPECT_THAT(c.stop(), HasSubstr("died of signal")) << "killed, or ended by the pipe stop() closed";
  // A zero wait still reads what has already arrived.
  ChildProcess quick(shell("echo ready; exec sleep 60"));
  for (int k = 0; k < 400 && quick.readLine(line, 0) != ChildProcess::Read::kLine; ++k) usleep(50000);
  EXPECT_EQ(line, "ready");
}

TEST(ChildProcess, WritingToAChildThatIsGoneIsFalseNotASignal) {
  ChildProcess c(shell("exit 3"));
  std::string line;
  EXPECT_EQ(c.readLine(line, 10), ChildProcess::Read::kEnd);
  // Its stdin's reader is gone: EPIPE, and no SIGPIPE ends this test process.
  bool sent = true;
  for (int i = 0; i < 100 && sent; ++i) sent = c.send(std::string(4096, 'x'));
  EXPECT_FALSE(sent);
  sigset_t pending;
  sigpending(&pending);
  EXPECT_EQ(sigismember(&pending, SIGPIPE), 0) << "no SIGPIPE left pending";
  EXPECT_EQ(c.stop(5), "exited with status 3");
}

TEST(ChildProcess, WhatCannotBeStartedIsRefusedWithItsReason) {
  auto why = [](const ChildSpec& spec) {
    try {
      ChildProcess c(spec);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(started)");
  };
  EXPECT_THAT(why({{"no-such-detector-program"}, {}, {}}), HasSubstr("no such program in PATH"));
  EXPECT_THAT(why({{"./missing.py"}, {}, {}}), HasSubstr("no such file"));
  EXPECT_THAT(why({{"scenes"}, {}, {}}), HasSubstr("no such program"));
  const fs::path dir = freshDir("refuse");
  std::ofstream(dir / "not_executable.py") << "print('hi')\n";
  EXPECT_THAT(why({{"./not_executable.py"}, dir, {}}), HasSubstr("not an executable file"));
  EXPECT_THAT(why({{"cat"}, dir / "nowhere", {}}), HasSubstr("is not a directory"));
  EXPECT_THAT(why({{"cat"}, {}, dir / "nowhere" / "err.log"}), HasSubstr("for a child's stderr"));
  EXPECT_THAT(why({{}, {}, {}}), HasSubstr("no program given"));
  // exec itself refuses (a script whose interpreter does not exist): its errno, reported by the child.
  std::ofstream(dir / "bad_interpreter.sh") << "#!/nonexistent/interpreter\n";
  fs::permissions(dir / "bad_interpreter.sh", fs::perms::owner_all);
  EXPECT_THAT(why({{"./bad_interpreter.sh"}, dir, {}}), HasSubstr("No such file or directory"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mm
