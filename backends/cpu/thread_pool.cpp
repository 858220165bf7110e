#include "cpu/thread_pool.hpp"

#include <algorithm>

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
  ++generation_;
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
    wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
    if (stop_) return;
    seen = generation_;
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
