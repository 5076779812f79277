// Shared by the fuzz targets: an input becomes a file (the loaders read files, as a user's input
// arrives), in a folder of this process's own; what a loader may throw is InputError (bad input,
// exit 2) — anything else escaping it is a finding, as a crash is.
#pragma once
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.h"

namespace mm::fuzz {

/// A folder of this process's own (under TMPDIR), made once.
inline const std::filesystem::path& workDir() {
  static const std::filesystem::path dir = [] {
    const auto d = std::filesystem::temp_directory_path() / ("minimanip_fuzz_" + std::to_string(getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

/// `data` written as `name` in workDir(); its path.
inline std::string asFile(const uint8_t* data, size_t size, const std::string& name) {
  const auto path = workDir() / name;
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path.string();
}

/// The repository's root (the targets run from it, or from MINIMANIP_SOURCE_DIR).
inline std::string repo(const std::string& rel) { return std::string(MINIMANIP_SOURCE_DIR) + "/" + rel; }

/// Runs `load`; InputError is the expected answer to bad input, anything else aborts (a finding).
template <class F>
void expectOnlyInputErrors(F&& load) {
  try {
    load();
  } catch (const InputError& e) {
    if (std::getenv("MINIMANIP_FUZZ_VERBOSE")) std::fprintf(stderr, "  bad input: %s\n", e.what());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "a loader threw something other than InputError: %s\n", e.what());
    std::abort();
  }
}

}  // namespace mm::fuzz
