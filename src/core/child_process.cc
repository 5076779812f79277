#include "core/child_process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace mm {

namespace fs = std::filesystem;

namespace {

bool isExecutableFile(const fs::path& p) {
  struct stat st {};
  return stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode) && access(p.c_str(), X_OK) == 0;
}

// In the child: `fd` becomes `target`, open across exec (dup2 onto itself would keep close-on-exec).
void moveTo(int fd, int target) {
  if (fd == target) fcntl(fd, F_SETFD, 0);
  else dup2(fd, target);
}

void closeFd(int& fd) {
  if (fd >= 0) close(fd);
  fd = -1;
}

// A descriptor moved above stdin, stdout and stderr (when one of those was closed, a new descriptor
// takes its number, and the child's moves onto 0, 1, 2 would then overwrite it before it is moved).
int aboveStdio(int fd) {
  if (fd < 0 || fd > STDERR_FILENO) return fd;
  const int moved = fcntl(fd, F_DUPFD_CLOEXEC, STDERR_FILENO + 1);
  close(fd);
  return moved;
}

}  // namespace

fs::path resolveProgram(const std::string& name, const fs::path& cwd) {
  if (name.find('/') != std::string::npos) {
    const fs::path p = fs::path(name).is_absolute() || cwd.empty() ? fs::path(name) : cwd / name;
    if (!fs::exists(p)) throw std::runtime_error("cannot start '" + name + "': no such file" + (cwd.empty() ? "" : " (from " + cwd.string() + ")"));
    if (!isExecutableFile(p)) throw std::runtime_error("cannot start '" + name + "': not an executable file");
    return fs::absolute(p);  // exec runs after the child's chdir
  }
  const char* env = std::getenv("PATH");
  const std::string path = env && *env ? env : "/usr/local/bin:/usr/bin:/bin";
  for (size_t start = 0; start <= path.size();) {
    const size_t end = std::min(path.find(':', start), path.size());
    const fs::path dir = end > start ? fs::path(path.substr(start, end - start)) : fs::path(".");
    if (isExecutableFile(dir / name)) return fs::absolute(dir / name);
    start = end + 1;
  }
  throw std::runtime_error("cannot start '" + name + "': no such program in PATH (" + path + ")");
}


std::string signalText(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  return "signal " + std::to_string(sig) + (abbrev ? std::string(" (SIG") + abbrev + ")" : "");
}

std::string exitText(int status) {
  if (WIFSIGNALED(status)) return "died of " + signalText(WTERMSIG(status));
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  return "ended (wait status " + std::to_string(status) + ")";
}

ChildPipes startChild(const ChildSpec& spec) {
  if (spec.argv.empty() || spec.argv[0].empty()) throw std::runtime_error("cannot start a child process: no program given");
  if (!spec.cwd.empty() && !fs::is_directory(spec.cwd))
    throw std::runtime_error("cannot start '" + spec.argv[0] + "': its working directory " + spec.cwd.string() + " is not a directory");
  const fs::path program = resolveProgram(spec.argv[0], spec.cwd);
  int err_fd = -1;
  if (!spec.stderr_file.empty()) {
    err_fd = open(spec.stderr_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (err_fd < 0) throw std::runtime_error("cannot open " + spec.stderr_file.string() + " for a child's stderr: " + std::strerror(errno));
    err_fd = aboveStdio(err_fd);
  }
  // to, from: the protocol; report: exec's errno, should exec fail (closed by a successful exec).
  int to[2] = {-1, -1}, from[2] = {-1, -1}, report[2] = {-1, -1};
  if (pipe2(to, O_CLOEXEC) != 0 || pipe2(from, O_CLOEXEC) != 0 || pipe2(report, O_CLOEXEC) != 0) {
    const int e = errno;
    for (int* p : {to, from, report}) closeFd(p[0]), closeFd(p[1]);
    closeFd(err_fd);
    throw std::runtime_error("pipe: " + std::string(std::strerror(e)));
  }
  for (int* p : {to, from, report}) p[0] = aboveStdio(p[0]), p[1] = aboveStdio(p[1]);
  std::vector<char*> argv;
  for (const std::string& a : spec.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const std::string cwd = spec.cwd.string();
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid == 0) {
    // The child: async-signal-safe calls only until exec.
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // dies with us, even by kill -9
    if (getppid() != parent) _exit(1);
    signal(SIGPIPE, SIG_DFL);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    moveTo(to[0], STDIN_FILENO);
    moveTo(from[1], STDOUT_FILENO);
    if (err_fd >= 0) moveTo(err_fd, STDERR_FILENO);
    if (cwd.empty() || chdir(cwd.c_str()) == 0) execv(program.c_str(), argv.data());
    const int e = errno;
    [[maybe_unused]] const ssize_t n = write(report[1], &e, sizeof e);
    _exit(127);
  }
  const int fork_errno = errno;
  close(to[0]);
  close(from[1]);
  close(report[1]);
  closeFd(err_fd);
  if (pid < 0) {
    close(to[1]), close(from[0]), close(report[0]);
    throw std::runtime_error("fork: " + std::string(std::strerror(fork_errno)));
  }
  int exec_errno = 0;
  ssize_t n;
  while ((n = read(report[0], &exec_errno, sizeof exec_errno)) < 0 && errno == EINTR) {
  }
  close(report[0]);
  if (n == static_cast<ssize_t>(sizeof exec_errno)) {
    while (waitpid(pid, nullptr, 0) < 0 && errno == EINTR) {
    }
    close(to[1]), close(from[0]);
    throw std::runtime_error("cannot start '" + program.string() + "': " + std::strerror(exec_errno));
  }
  return {pid, to[1], from[0]};
}

bool sendLine(int fd, const std::string& line) {
  if (fd < 0) return false;
  // SIGPIPE blocked for this write: a reader that is gone is EPIPE here, and the signal it leaves
  // pending is taken back before the mask is restored.
  sigset_t pipe_only, old, pending;
  sigemptyset(&pipe_only);
  sigaddset(&pipe_only, SIGPIPE);
  sigpending(&pending);
  const bool was_pending = sigismember(&pending, SIGPIPE) == 1;
  pthread_sigmask(SIG_BLOCK, &pipe_only, &old);
  const std::string s = line + "\n";
  size_t off = 0;
  bool ok = true;
  while (off < s.size()) {
    const ssize_t n = write(fd, s.data() + off, s.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ok = false;
      break;
    }
    off += static_cast<size_t>(n);
  }
  if (!ok && !was_pending) {
    const timespec zero{0, 0};
    while (sigtimedwait(&pipe_only, nullptr, &zero) < 0 && errno == EINTR) {
    }
  }
  pthread_sigmask(SIG_SETMASK, &old, nullptr);
  return ok;
}

ChildProcess::ChildProcess(const ChildSpec& spec) : pipes_(startChild(spec)) {}

ChildProcess::~ChildProcess() { release(); }

ChildProcess::ChildProcess(ChildProcess&& other) noexcept
    : pipes_(other.pipes_), buffer_(std::move(other.buffer_)), searched_(other.searched_) {
  other.pipes_ = ChildPipes{};
  other.searched_ = 0;
}

ChildProcess& ChildProcess::operator=(ChildProcess&& other) noexcept {
  if (this != &other) {
    release();
    pipes_ = other.pipes_;
    buffer_ = std::move(other.buffer_);
    searched_ = other.searched_;
    other.pipes_ = ChildPipes{};
    other.searched_ = 0;
  }
  return *this;
}

void ChildProcess::release() noexcept {
  closeFd(pipes_.to);
  closeFd(pipes_.from);
  if (pipes_.pid > 0) {
    kill(pipes_.pid, SIGKILL);
    while (waitpid(pipes_.pid, nullptr, 0) < 0 && errno == EINTR) {
    }
  }
  pipes_.pid = -1;
  buffer_.clear();
  searched_ = 0;
}

bool ChildProcess::send(const std::string& line) { return sendLine(pipes_.to, line); }

void ChildProcess::closeInput() { closeFd(pipes_.to); }

ChildProcess::Read ChildProcess::readLine(std::string& line, double timeout_s) {
  using Clock = std::chrono::steady_clock;
  // At most a day: a larger cap is no cap, and would overflow the clock's arithmetic.
  const double cap = std::isfinite(timeout_s) ? std::clamp(timeout_s, 0.0, 86400.0) : timeout_s > 0 ? 86400.0 : 0.0;
  const Clock::time_point deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(cap));
  for (;;) {
    if (const size_t nl = buffer_.find('\n', searched_); nl != std::string::npos) {
      line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      searched_ = 0;
      return Read::kLine;
    }
    searched_ = buffer_.size();  // a long line is searched once, not once per read
    if (buffer_.size() > kMaxLine) {
      buffer_.clear();
      searched_ = 0;
      return Read::kTooLong;
    }
    if (pipes_.from < 0) return Read::kEnd;
    // What has arrived is read even when the time is up (a zero timeout reads what is waiting).
    const double left = std::chrono::duration<double>(deadline - Clock::now()).count();
    pollfd p{pipes_.from, POLLIN, 0};
    const int r = poll(&p, 1, left > 0 ? static_cast<int>(std::ceil(left * 1000)) : 0);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw std::runtime_error("poll: " + std::string(std::strerror(errno)));
    if (r == 0) {
      if (left <= 0) return Read::kTimeout;
      continue;
    }
    char buf[65536];
    const ssize_t n = read(pipes_.from, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {  // its end: a half line it left is dropped
      closeFd(pipes_.from);
      buffer_.clear();
      searched_ = 0;
      return Read::kEnd;
    }
    buffer_.append(buf, static_cast<size_t>(n));
  }
}

std::string ChildProcess::stop(double grace_s) {
  closeFd(pipes_.to);
  closeFd(pipes_.from);
  buffer_.clear();
  searched_ = 0;
  if (pipes_.pid <= 0) return "";
  const pid_t pid = pipes_.pid;
  pipes_.pid = -1;
  int status = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(std::max(0.0, grace_s));
  for (;;) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return exitText(status);
    if (r < 0 && errno != EINTR) return "gone (" + std::string(std::strerror(errno)) + ")";
    if (std::chrono::steady_clock::now() >= until) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(pid, SIGKILL);
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return exitText(status);
}

}  // namespace mm
