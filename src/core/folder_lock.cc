#include "core/folder_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <string>

#include "core/error.h"
#include "core/file_io.h"

namespace mm {

namespace {

std::string readAll(int fd) {
  std::string text;
  char buf[256];
  for (off_t at = 0;;) {
    const ssize_t n = ::pread(fd, buf, sizeof buf, at);
    if (n <= 0) break;
    text.append(buf, static_cast<size_t>(n));
    at += n;
    if (text.size() > 4096) break;
  }
  while (!text.empty() && (text.back() == '\n' || text.back() == '\0')) text.pop_back();
  return text;
}

std::string thisHost() {
  char buf[256] = "";
  ::gethostname(buf, sizeof buf - 1);
  return buf;
}

}  // namespace

FolderLock::FolderLock(const std::filesystem::path& dir, const std::string& command, std::string* note) {
  createDirectories(dir);
  lock(dir / kFileName, dir, command, note);
}

FolderLock FolderLock::claimBeforeStart(const std::filesystem::path& dir, const std::string& command) {
  namespace fs = std::filesystem;
  const std::string key = fs::absolute(dir).lexically_normal().string();
  uint64_t h = 1469598103934665603ull;  // FNV-1a of the folder's absolute path
  for (const unsigned char c : key) h = (h ^ c) * 1099511628211ull;
  char name[40];
  std::snprintf(name, sizeof name, "%016llx.lock", static_cast<unsigned long long>(h));
  const fs::path claims = fs::temp_directory_path() / ("minimanip-claims-" + std::to_string(::getuid()));
  createDirectories(claims);
  FolderLock claim;
  claim.lock(claims / name, dir, command, nullptr);
  return claim;
}

void FolderLock::lock(const std::filesystem::path& file, const std::filesystem::path& dir, const std::string& command, std::string* note) {
  fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  // On a read-only file system no one writes the folder, and reading it (a resume with nothing to
  // do) needs no more than a lock on the file as it is: a read-only descriptor takes a flock too.
  if (fd_ < 0 && errno == EROFS) fd_ = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw OutputError(file.string(), errnoText(errno == ENOENT ? EROFS : errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    const std::string holder = readAll(fd_);
    ::close(fd_);
    fd_ = -1;
    if (err != EWOULDBLOCK) throw OutputError(file.string(), "cannot lock: " + errnoText(err));
    const bool in_folder = file.parent_path() == dir;
    throw InputError(dir.string(), "in use by another process (" + (holder.empty() ? std::string("pid unknown") : holder) + "), which " +
                                       (in_folder ? "holds " + file.string() : std::string("started on it first")) +
                                       ": one process writes a results folder at a time; wait for it, stop it, or use another --out");
  }
  // Ours now. A pid left in the file is a holder that ended without clearing it (killed).
  const std::string left = readAll(fd_);
  if (note && !left.empty()) *note = "took over " + file.string() + " from " + left + ", which is no longer running";
  const std::string me = "pid " + std::to_string(::getpid()) + " on " + thisHost() + ", " + command + "\n";
  // The pid is for people; the flock is the lock. A full disk may refuse even these few bytes:
  // the lock holds all the same.
  if (::ftruncate(fd_, 0) == 0) (void)!::pwrite(fd_, me.data(), me.size(), 0);
}

FolderLock::~FolderLock() {
  if (fd_ < 0) return;
  (void)!::ftruncate(fd_, 0);  // a clean end: nothing to take over
  ::flock(fd_, LOCK_UN);
  ::close(fd_);
}

}  // namespace mm
