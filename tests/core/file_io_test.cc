#include "core/file_io.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "core/folder_lock.h"
#include "core/utf8.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

struct Dir {
  fs::path path = fs::temp_directory_path() / ("mm_file_io_" + std::to_string(getpid()));
  Dir() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Dir() { fs::remove_all(path); }
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(Utf8, WellFormedOnly) {
  EXPECT_EQ(firstInvalidUtf8("plain ascii"), std::string_view::npos);
  EXPECT_EQ(firstInvalidUtf8("caf\xc3\xa9 \xe2\x9c\x93 \xf0\x9f\xa4\x96"), std::string_view::npos);
  EXPECT_EQ(firstInvalidUtf8("caf\xe9"), 3u);              // Latin-1
  EXPECT_EQ(firstInvalidUtf8("\xc0\xaf"), 0u);             // overlong '/'
  EXPECT_EQ(firstInvalidUtf8("ab\xed\xa0\x80"), 2u);       // a UTF-16 surrogate
  EXPECT_EQ(firstInvalidUtf8("\xf4\x90\x80\x80"), 0u);     // past U+10FFFF
  EXPECT_EQ(firstInvalidUtf8("x\xe2\x9c"), 1u);            // cut short
  EXPECT_EQ(firstInvalidUtf8("\xff"), 0u);
  try {
    requireUtf8File("a: 1\nbb: x\xff\n", "f.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "f.yaml:2:6: not valid UTF-8 (byte 0xFF; expected UTF-8 text)");
  }
}

TEST(FileIo, AtomicWritesLeaveNoTemporaryAndNameTheCause) {
  Dir d;
  writeFileAtomically(d.path / "a.json", "{}\n");
  EXPECT_EQ(slurp(d.path / "a.json"), "{}\n");
  EXPECT_FALSE(fs::exists(d.path / "a.json.tmp"));
  EXPECT_FALSE(writeFileIfChanged(d.path / "a.json", "{}\n"));  // the same text: nothing written
  EXPECT_TRUE(writeFileIfChanged(d.path / "a.json", "{ }\n"));
  // A folder that is not there: the path and the system's reason.
  try {
    writeFileAtomically(d.path / "missing" / "b.json", "x");
    FAIL();
  } catch (const OutputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("missing/b.json: No such file or directory"));
  }
  // A full disk (/dev/full answers every write with ENOSPC).
  try {
    AppendFile full("/dev/full");
    full.appendLine("a record");
    FAIL();
  } catch (const OutputError& e) {
    EXPECT_EQ(e.cause(), "No space left on device");
    EXPECT_THAT(e.what(), HasSubstr("cannot write /dev/full: No space left on device"));
  }
  try {
    createDirectories(d.path / "a.json" / "sub");  // under a file
    FAIL();
  } catch (const OutputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("a.json"));
  }
}

TEST(FolderLock, OneHolderAtATimeAndAStaleLockIsTakenOver) {
  Dir d;
  {
    const FolderLock first(d.path / "out", "test one");
    // Another process (flock locks belong to open files: a child opens its own).
    const pid_t child = fork();
    if (child == 0) {
      try {
        FolderLock second(d.path / "out", "test two");
        _exit(0);
      } catch (const InputError& e) {
        const std::string what = e.what();
        _exit(what.find("in use by another process (pid " + std::to_string(getppid())) != std::string::npos &&
                      what.find("test one") != std::string::npos
                  ? 7
                  : 8);
      }
    }
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 7) << "the second holder was not refused with the first one's pid";
  }
  // Released at a clean end: the next one takes it without a word.
  {
    std::string note;
    const FolderLock again(d.path / "out", "test three", &note);
    EXPECT_EQ(note, "");
  }
  // A holder killed with its lock: the kernel released the flock, the file still names it.
  const pid_t child = fork();
  if (child == 0) {
    FolderLock held(d.path / "out", "test four");
    _exit(0);  // no destructor: as a kill -9
  }
  int status = 0;
  waitpid(child, &status, 0);
  std::string note;
  const FolderLock after(d.path / "out", "test five", &note);
  EXPECT_THAT(note, HasSubstr("took over"));
  EXPECT_THAT(note, HasSubstr("pid " + std::to_string(child)));
  EXPECT_THAT(note, HasSubstr("no longer running"));
}

}  // namespace
}  // namespace mm
