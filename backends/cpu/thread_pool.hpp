// A fixed pool of worker threads for the cpu backend's data-parallel loops. Each index of a
// parallel_for is handled exactly once and kernels write disjoint outputs per index, so results
// never depend on the number of threads or on scheduling.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace porta::cpu {

class ThreadPool {
 public:
  /// Most threads a pool takes: more is a mistake, not a machine (and each costs a stack).
  static constexpr int kMaxThreads = 1024;
  /// `threads` 0 = std::thread::hardware_concurrency(). The workers take the name `name` (what a
  /// profiler and `portaslam run`'s CPU by thread show). Throws std::invalid_argument for `threads`
  /// outside [0, kMaxThreads] or a null or empty `name`, std::runtime_error (no thread left
  /// running) when the system refuses one.
  explicit ThreadPool(int threads = 0, const char* name = "porta-pool");
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return static_cast<int>(workers_.size()) + 1; }

  /// Calls fn(i) for every i in [begin, end), split into contiguous chunks over the pool and the
  /// calling thread; returns when all are done. Not reentrant.
  void parallel_for(std::int64_t begin, std::int64_t end, const std::function<void(std::int64_t)>& fn);

 private:
  void worker_loop();
  void stop_workers();
  /// Waits (spinning, then yielding) until no worker is inside a job.
  void wait_for_workers_outside() const;

  std::vector<std::thread> workers_;
  // Job hand-off without a lock per chunk. The generation is odd while the caller sets a job up
  // and even once it is ready; a worker enters a job by incrementing inside_ and re-checking the
  // generation (both sequentially consistent, so either the worker sees the set-up start and
  // leaves, or the caller sees the worker inside and waits), then claims chunks with fetch_add.
  // The job fields change only while the generation is odd and no worker is inside.
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<int> inside_{0};
  std::atomic<std::int64_t> next_{0};
  const std::function<void(std::int64_t)>* job_ = nullptr;
  std::int64_t end_ = 0, chunk_ = 1;
  std::atomic<bool> stop_{false};
  // Sleeping workers wait here; the caller takes the mutex to publish a job, so none misses it.
  std::mutex mutex_;
  std::condition_variable wake_;
  static constexpr std::chrono::microseconds kSpinBeforeSleep{200};
};

}  // namespace porta::cpu
