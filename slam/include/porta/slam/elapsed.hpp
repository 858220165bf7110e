// Nanoseconds since a steady-clock time point: the stage timings of tracking, mapping, loop
// closing and the pipeline.
#pragma once

#include <chrono>
#include <cstdint>

namespace porta::slam {

inline std::int64_t elapsed_ns(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace porta::slam
