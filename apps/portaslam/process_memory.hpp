// The process's resident memory, for the run report's memory samples (docs/RELIABILITY.md, soak).
#pragma once

#include <cstdio>
#include <unistd.h>

namespace porta::app {

/// Resident set size in MiB from /proc/self/statm (Linux); 0 where it cannot be read.
inline double resident_mib() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (f == nullptr) return 0.0;
  unsigned long long pages_total = 0, pages_resident = 0;
  const int got = std::fscanf(f, "%llu %llu", &pages_total, &pages_resident);
  std::fclose(f);
  if (got != 2) return 0.0;
  return static_cast<double>(pages_resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

}  // namespace porta::app
