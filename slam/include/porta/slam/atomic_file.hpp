// Files written whole or not at all: every file PortaSLAM writes (trajectories, reports, maps,
// rendered images) goes to a temporary file in the target's folder, is synced, then renamed over
// the target, so that a crash, a full disk or a kill mid-write leaves the previous file (or none),
// never a truncated one.
#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

namespace porta::slam {

/// A file could not be written; what() names the file, the step and the system's reason, and
/// says that the previous file, if any, is unchanged.
class AtomicWriteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Writes `bytes` to `path` atomically (temporary `path.tmp.<pid>.<n>` created with O_EXCL, written,
/// fsync'ed, renamed over `path`; the folder is synced afterwards, best effort). On any failure the
/// temporary is removed and AtomicWriteError is thrown.
void write_file_atomically(const std::string& path, std::span<const std::uint8_t> bytes);
void write_file_atomically(const std::string& path, std::string_view text);

}  // namespace porta::slam
