#include "cpu/thread_pool.hpp"

#include <algorithm>
#include <chrono>

namespace porta::cpu {

ThreadPool::ThreadPool(int threads) {
  int n = threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency());
  n = std::max(1, n);
  for (int i = 0; i + 1 < n; ++i) workers_.emplace_back([this] { worker_loop(); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    stop_flag_ = true;
  }
  wake_.notify_all();
  for (auto& t : workers_) t.join();
}

void ThreadPool::parallel_for(std::int64_t begin, std::int64_t end, const std::function<void(std::int64_t)>& fn) {
  if (end <= begin) return;
  if (workers_.empty() || end - begin == 1) {
    for (std::int64_t i = begin; i < end; ++i) fn(i);
    return;
  }
  std::unique_lock lock(mutex_);
  job_ = &fn;
  next_ = begin;
  end_ = end;
  chunk_ = std::max<std::int64_t>(1, (end - begin) / (static_cast<std::int64_t>(size()) * 4));
  running_ = 0;
  generation_.fetch_add(1, std::memory_order_release);
  lock.unlock();
  wake_.notify_all();
  for (;;) {  // the calling thread works too
    lock.lock();
    const std::int64_t a = next_, b = std::min(end_, a + chunk_);
    next_ = b;
    lock.unlock();
    if (a >= b) break;
    for (std::int64_t i = a; i < b; ++i) fn(i);
  }
  // Every chunk is claimed; wait only for chunks still running. A worker the scheduler has not
  // run yet (the cores busy elsewhere, e.g. with SLAM's mapping thread) finds no work when it
  // wakes and is not waited for.
  lock.lock();
  done_.wait(lock, [this] { return running_ == 0; });
  job_ = nullptr;
}

void ThreadPool::worker_loop() {
  std::uint64_t seen = 0;
  std::unique_lock lock(mutex_);
  for (;;) {
    if (generation_.load(std::memory_order_relaxed) == seen && !stop_) {
      // A frame calls parallel_for dozens of times back to back: spin a little before sleeping,
      // so that the next call finds this worker awake (waking a sleeping thread costs tens of
      // microseconds, more on a virtual machine whose idle core has halted).
      lock.unlock();
      const auto spin_until = std::chrono::steady_clock::now() + kSpinBeforeSleep;
      for (int k = 1; generation_.load(std::memory_order_acquire) == seen && !stop_flag_.load(std::memory_order_relaxed);
           ++k) {
        if (k % 64 == 0 && std::chrono::steady_clock::now() >= spin_until) break;
        std::this_thread::yield();
      }
      lock.lock();
      wake_.wait(lock, [&] { return stop_ || generation_.load(std::memory_order_relaxed) != seen; });
    }
    if (stop_) return;
    seen = generation_.load(std::memory_order_relaxed);
    for (;;) {
      const std::int64_t a = next_, b = std::min(end_, a + chunk_);
      if (a >= b) break;
      next_ = b;
      ++running_;
      const auto* fn = job_;
      lock.unlock();
      for (std::int64_t i = a; i < b; ++i) (*fn)(i);
      lock.lock();
      if (--running_ == 0 && next_ >= end_) done_.notify_all();
    }
  }
}

}  // namespace porta::cpu
