#include "core/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <system_error>

#include "core/error.h"

namespace mm {

namespace fs = std::filesystem;

std::string errnoText(int err) { return std::strerror(err); }

void createDirectories(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) {
    // Name the part of the path that could not be made, not only the whole.
    fs::path made = dir;
    while (made.has_parent_path() && made.parent_path() != made && !fs::exists(made.parent_path())) made = made.parent_path();
    throw OutputError(made.string(), ec.message());
  }
  if (!fs::is_directory(dir)) throw OutputError(dir.string(), "exists and is not a folder");
}

namespace {

// Writes all of [data, data + size) to fd; returns 0 or the errno of the failure.
int writeAll(int fd, const char* data, size_t size) {
  size_t done = 0;
  while (done < size) {
    const ssize_t n = ::write(fd, data + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno;
    if (n == 0) return ENOSPC;
    done += static_cast<size_t>(n);
  }
  return 0;
}

}  // namespace

void writeFileBytes(const fs::path& path, const void* data, size_t size) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw OutputError(path.string(), errnoText(errno));
  int err = writeAll(fd, static_cast<const char*>(data), size);
  if (::close(fd) != 0 && err == 0) err = errno;  // a delayed write error (NFS, quotas) shows here
  if (err != 0) {
    ::unlink(path.c_str());
    throw OutputError(path.string(), errnoText(err));
  }
}

void writeFileAtomically(const fs::path& path, std::string_view text) {
  const fs::path tmp = path.string() + ".tmp";
  try {
    writeFileBytes(tmp, text.data(), text.size());  // removes its file on failure
  } catch (const OutputError& e) {
    throw OutputError(path.string(), e.cause());  // the file meant, not its temporary name
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw OutputError(path.string(), errnoText(err));
  }
}

bool writeFileIfChanged(const fs::path& path, std::string_view text) {
  {
    std::ifstream in(path, std::ios::binary);
    if (in) {
      const std::string there((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (there == text) return false;
    }
  }
  writeFileAtomically(path, text);
  return true;
}

AppendFile::AppendFile(fs::path path) : path_(std::move(path)) {
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) throw OutputError(path_.string(), errnoText(errno));
}

AppendFile::~AppendFile() { close(); }

AppendFile::AppendFile(AppendFile&& other) noexcept : path_(std::move(other.path_)), fd_(other.fd_) { other.fd_ = -1; }

AppendFile& AppendFile::operator=(AppendFile&& other) noexcept {
  if (this != &other) {
    close();
    path_ = std::move(other.path_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

void AppendFile::appendLine(std::string_view line) {
  std::string text;
  text.reserve(line.size() + 1);
  text.append(line);
  text.push_back('\n');
  append(text);
}

void AppendFile::append(std::string_view text) {
  MM_DEMAND(fd_ >= 0);
  struct stat before {};
  const bool sized = ::fstat(fd_, &before) == 0;
  const int err = writeAll(fd_, text.data(), text.size());
  if (err != 0) {
    // A part of the line may have reached the file (a disk filling up): cut it off again, so the
    // file ends with a whole record as before.
    if (sized) (void)::ftruncate(fd_, before.st_size);
    throw OutputError(path_.string(), errnoText(err));
  }
}

void AppendFile::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

}  // namespace mm
