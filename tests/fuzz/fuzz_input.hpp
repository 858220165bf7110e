// Shared by the fuzz targets (tests/fuzz, docs/RELIABILITY.md): every parser of PortaSLAM reads a
// path, so each input is written to a file of this process first. A target catches exactly the
// error types its parser documents; anything else (another exception, a crash, a sanitizer report,
// a hang, a huge allocation) is a finding.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>

namespace porta::fuzz {

namespace fs = std::filesystem;

/// Where inputs are written: $PORTA_FUZZ_SCRATCH, else /dev/shm (memory: a file per execution
/// costs no disk), else the temporary directory.
inline fs::path scratch_root() {
  if (const char* env = std::getenv("PORTA_FUZZ_SCRATCH"); env != nullptr && *env != '\0') return env;
  std::error_code error;
  if (fs::is_directory("/dev/shm", error) && ::access("/dev/shm", W_OK) == 0) return "/dev/shm";
  return fs::temp_directory_path();
}

/// A folder of this process under scratch_root(), made once and removed at exit.
inline const fs::path& scratch_folder() {
  static const struct Folder {
    fs::path path;
    Folder() : path(scratch_root() / ("porta-fuzz-" + std::to_string(::getpid()))) {
      fs::create_directories(path);
    }
    ~Folder() {
      std::error_code ignored;
      fs::remove_all(path, ignored);
    }
  } folder;
  return folder.path;
}

/// Writes `bytes` to `path` (replacing it) and returns the path as a string.
inline std::string write_input(const fs::path& path, std::span<const std::uint8_t> bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return path.string();
}

/// A documented error was thrown: printed when PORTA_FUZZ_REPORT is set (to see which inputs get
/// how far; the seeds must pass), else ignored.
inline void expected(const std::exception& e) {
  static const bool report = std::getenv("PORTA_FUZZ_REPORT") != nullptr;
  if (report) std::fprintf(stderr, "refused: %s\n", e.what());
}

inline std::span<const std::uint8_t> as_span(const std::uint8_t* data, std::size_t size) { return {data, size}; }

}  // namespace porta::fuzz
