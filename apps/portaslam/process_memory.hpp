// The process's resident memory and CPU time, for the run report (memory samples:
// docs/RELIABILITY.md, soak; host CPU seconds per frame: docs/BENCHMARKS.md).
#pragma once

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>

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

/// CPU time (user + system) of every thread of the process so far, in seconds.
inline double process_cpu_seconds() {
  rusage usage{};
  if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

/// The largest resident set size the process has had, in MiB (Linux reports KiB).
inline double peak_resident_mib() {
  rusage usage{};
  if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  return static_cast<double>(usage.ru_maxrss) / 1024.0;
}

}  // namespace porta::app
