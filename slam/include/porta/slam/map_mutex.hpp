// Map::mutex: a std::mutex that adds up, per thread, how long that thread waited to take it, so
// that local mapping can say how much of a keyframe's time it spent waiting for tracking's hold of
// the map (mapping.csv's lock_wait_ms) rather than working.
#pragma once

#include <chrono>
#include <cstdint>
#include <mutex>

#include "porta/slam/elapsed.hpp"

namespace porta::slam {

class MapMutex {
 public:
  void lock() {
    if (mutex_.try_lock()) return;  // not contended: nothing waited, no clock read
    const auto start = std::chrono::steady_clock::now();
    mutex_.lock();
    thread_wait_ns_ += elapsed_ns(start);
  }
  bool try_lock() { return mutex_.try_lock(); }
  void unlock() { mutex_.unlock(); }

  /// Nanoseconds the calling thread has waited for any MapMutex since it started.
  static std::int64_t thread_wait_ns() { return thread_wait_ns_; }

 private:
  std::mutex mutex_;
  static inline thread_local std::int64_t thread_wait_ns_ = 0;
};

}  // namespace porta::slam
