// Errors: bad user input (exit code 2), results that cannot be written (exit code 3) and our own
// broken invariants (exit code 1).
#pragma once
#include <stdexcept>
#include <string>

namespace mm {

/// Bad input from the user: a file, a config key or value, a command-line argument.
/// `where` names the file and place (e.g. "experiments/q.yaml:12:3" or "--set grasp.mode"),
/// the message says what was expected. The CLI turns it into exit code 2 before any trial runs.
class InputError : public std::runtime_error {
 public:
  InputError(std::string where, const std::string& what)
      : std::runtime_error(where + ": " + what), where_(std::move(where)) {}
  const std::string& where() const { return where_; }

 private:
  std::string where_;
};

/// A file or folder that cannot be written: `path` and the system's `cause` (disk full, read-only
/// file system, permission denied, ...). Not a bug and not bad input: the CLI exits with code 3,
/// and what was written before stays complete (appends are per line, summaries renamed into place).
class OutputError : public std::runtime_error {
 public:
  OutputError(std::string path, std::string cause)
      : std::runtime_error("cannot write " + path + ": " + cause), path_(std::move(path)), cause_(std::move(cause)) {}
  const std::string& path() const { return path_; }
  const std::string& cause() const { return cause_; }

 private:
  std::string path_, cause_;
};

/// Throws std::logic_error for a broken internal invariant (exit code 1): a bug of ours.
[[noreturn]] void internalError(const std::string& what);

#define MM_DEMAND(cond)                                                        \
  do {                                                                         \
    if (!(cond)) ::mm::internalError(std::string(__FILE__) + ":" +             \
                                     std::to_string(__LINE__) + ": " #cond);   \
  } while (0)

}  // namespace mm
