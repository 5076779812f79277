// Writing results so that nothing written is lost and nothing half-written is left: whole files
// by temporary name + rename, records by appended lines, folders created with their cause of
// failure. Every failure is an OutputError naming the path and the system's reason (errno).
#pragma once
#include <filesystem>
#include <string>
#include <string_view>

namespace mm {

/// Creates `dir` and its parents (nothing when it exists). OutputError on failure.
void createDirectories(const std::filesystem::path& dir);

/// Writes `text` to `path` through `path`.tmp and a rename: readers see the old file or the
/// new one, never a part. The temporary is removed on every failure path. OutputError on failure.
void writeFileAtomically(const std::filesystem::path& path, std::string_view text);

/// Writes `size` bytes to `path` (created or truncated), in one write(2) where it can; the file is
/// removed again when the write fails. OutputError on failure.
void writeFileBytes(const std::filesystem::path& path, const void* data, size_t size);

/// `text` unless it is empty and `path` already holds exactly `text`: writes only what changed
/// (a resume with nothing to do writes nothing). Returns whether it wrote.
bool writeFileIfChanged(const std::filesystem::path& path, std::string_view text);

/// A file opened for appending records, one write(2) per line (a line is never split between two
/// writers' records, and a killed process leaves at most one half line, without its newline).
class AppendFile {
 public:
  AppendFile() = default;
  /// Opens (creates) `path` for appending. OutputError on failure.
  explicit AppendFile(std::filesystem::path path);
  ~AppendFile();
  AppendFile(AppendFile&& other) noexcept;
  AppendFile& operator=(AppendFile&& other) noexcept;
  AppendFile(const AppendFile&) = delete;
  AppendFile& operator=(const AppendFile&) = delete;

  /// Appends `line` and a newline. OutputError on failure (a partial write is cut back off).
  void appendLine(std::string_view line);
  /// Appends `text` as it is (whole lines, say, gathered for speed); likewise.
  void append(std::string_view text);
  void close();
  bool isOpen() const { return fd_ >= 0; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

/// The errno text for `err`, e.g. "No space left on device".
std::string errnoText(int err);

}  // namespace mm
