// A child process that speaks a line protocol over its stdin and stdout: the campaign's workers, and
// the external components a tree calls (a user's grasp detector, in any language). It is started with
// a pipe on each of the two, its stderr appended to a file of ours (or left as ours), and it dies with
// the thread that started it (PR_SET_PDEATHSIG follows the thread: start it from one that lives as
// long as it, as the main thread does), even by kill -9. Reading waits at most a given wall time: a
// child that hangs is seen as such, and one that crashes as the end of its output and the signal it
// died of. Writing does not wait on a child that never reads: a pipe holds 64 KiB, and a request
// line is far shorter.
#pragma once
#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace mm {

struct ChildSpec {
  std::vector<std::string> argv;      ///< argv[0]: a path, or a program's name looked up in PATH
  std::filesystem::path cwd;          ///< its working directory; empty: ours
  std::filesystem::path stderr_file;  ///< its stderr, appended (created when missing); empty: ours
};

/// The pipes of a started child (raw descriptors, for a caller that polls several children).
struct ChildPipes {
  pid_t pid = -1;
  int to = -1;    ///< its stdin
  int from = -1;  ///< its stdout
};

/// The file exec would run for `name`: `name` itself when it names a path (relative to `cwd`, the
/// child's working directory, when not empty), else the first executable of that name in PATH, as a
/// shell finds it; absolute. Throws std::runtime_error, saying why, when there is none.
std::filesystem::path resolveProgram(const std::string& name, const std::filesystem::path& cwd);

/// Starts `spec`. Throws std::runtime_error, saying which program and why, when it cannot be started:
/// no such program in PATH, not executable, a working directory or stderr file that cannot be used,
/// exec refused. Both descriptors are close-on-exec in this process.
ChildPipes startChild(const ChildSpec& spec);

/// Writes `line` and a newline to `fd`; false when the reader is gone (EPIPE: no SIGPIPE is raised,
/// and its end is seen on its output).
bool sendLine(int fd, const std::string& line);

/// "signal 11 (SIGSEGV)".
std::string signalText(int sig);

/// How a child ended, from waitpid's status: "exited with status 3", "died of signal 11 (SIGSEGV)".
std::string exitText(int status);

/// One child, its pipes and its output not yet read as lines. Moves, does not copy; destroying it
/// kills (SIGKILL) and reaps the child.
class ChildProcess {
 public:
  ChildProcess() = default;
  explicit ChildProcess(const ChildSpec& spec);  ///< startChild's errors
  ~ChildProcess();
  ChildProcess(ChildProcess&& other) noexcept;
  ChildProcess& operator=(ChildProcess&& other) noexcept;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool running() const { return pipes_.pid > 0; }
  pid_t pid() const { return pipes_.pid; }

  /// Writes `line` and a newline to its stdin; false when it is gone or its stdin was closed.
  bool send(const std::string& line);
  /// Closes its stdin (a child reading to the end of its input then exits).
  void closeInput();

  enum class Read { kLine, kEnd, kTimeout, kTooLong };
  /// The longest line readLine takes.
  static constexpr size_t kMaxLine = size_t{64} << 20;
  /// The next line of its stdout, without the newline, waiting at most `timeout_s` seconds of wall
  /// time. kEnd: its stdout closed (it exited or died; a half line it left is dropped); kTimeout:
  /// nothing complete within the time (it keeps running: stop() ends it); kTooLong: more than
  /// kMaxLine bytes without a newline (what it sent is dropped; stop() ends it).
  Read readLine(std::string& line, double timeout_s);

  /// Ends it: closes its pipes, waits up to `grace_s` seconds for it to exit by itself, then kills it
  /// (SIGKILL), reaps it and says how it ended (exitText: "died of signal 9 (SIGKILL)" when we killed
  /// it). Nothing when it was not running.
  std::string stop(double grace_s = 0.0);

 private:
  void release() noexcept;
  ChildPipes pipes_;
  std::string buffer_;
  size_t searched_ = 0;  ///< bytes at buffer_'s start known to hold no newline
};

}  // namespace mm
