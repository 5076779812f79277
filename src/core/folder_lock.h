// One writer per results folder: an exclusive advisory lock (flock(2)) on <folder>/.lock, held
// for the life of a FolderLock and released by the kernel when its process ends, however it ends.
// The file holds the holder's pid and host, so a refused second writer can name it, and a
// lock left by a process that died is known as such when the next one takes it.
#pragma once
#include <filesystem>
#include <string>

namespace mm {

class FolderLock {
 public:
  /// Locks `dir` (created when missing) for `command` ("minimanip run", ...). A folder locked by a
  /// live process throws InputError naming that process; a lock file left by a process that is
  /// gone is taken over, and `note` (when given) says so. Folders that cannot be created or
  /// written throw OutputError.
  FolderLock(const std::filesystem::path& dir, const std::string& command, std::string* note = nullptr);
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

  /// The claim on `dir` a process takes as it starts, before its input is checked and before
  /// anything is written there: a lock file of this machine's temporary folder named after the
  /// folder's absolute path. Of two runs started on one machine for one folder, the first started
  /// keeps it and the second is refused at once (InputError naming the first), however long the
  /// first takes to check its input; the folder's own lock (the constructor), taken once the
  /// input is accepted, covers other machines sharing the folder.
  static FolderLock claimBeforeStart(const std::filesystem::path& dir, const std::string& command);

  /// The lock file's name inside a locked folder (readers of a folder skip it).
  static constexpr const char* kFileName = ".lock";

  FolderLock(FolderLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

 private:
  FolderLock() = default;
  /// Locks `file`, messages naming `dir`.
  void lock(const std::filesystem::path& file, const std::filesystem::path& dir, const std::string& command, std::string* note);
  int fd_ = -1;
};

}  // namespace mm
