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
  /// `threads` 0 = std::thread::hardware_concurrency().
  explicit ThreadPool(int threads = 0);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return static_cast<int>(workers_.size()) + 1; }

  /// Calls fn(i) for every i in [begin, end), split into contiguous chunks over the pool and the
  /// calling thread; returns when all are done. Not reentrant.
  void parallel_for(std::int64_t begin, std::int64_t end, const std::function<void(std::int64_t)>& fn);

 private:
  void worker_loop();

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(std::int64_t)>* job_ = nullptr;
  std::int64_t next_ = 0, end_ = 0, chunk_ = 1;
  int running_ = 0;  // chunks being run by workers
  std::atomic<std::uint64_t> generation_{0};  // written under mutex_; workers spin on it
  std::atomic<bool> stop_flag_{false};         // stop_, readable while spinning
  static constexpr std::chrono::microseconds kSpinBeforeSleep{200};
  bool stop_ = false;
};

}  // namespace porta::cpu
