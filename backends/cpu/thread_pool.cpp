#include "cpu/thread_pool.hpp"

#include "cpu/thread_name.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>
#include <system_error>

namespace porta::cpu {

ThreadPool::ThreadPool(int threads, const char* name) {
  if (name == nullptr || *name == '\0') {
    throw std::invalid_argument("cpu backend: a thread pool needs a name for its workers, got " +
                                std::string(name == nullptr ? "none" : "an empty one"));
  }
  if (threads < 0 || threads > kMaxThreads) {
    throw std::invalid_argument("cpu backend: threads must be in [0, " + std::to_string(kMaxThreads) +
                                "] (0 = all hardware threads), got " + std::to_string(threads));
  }
  int n = threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency());
  n = std::clamp(n, 1, kMaxThreads);
  try {
    for (int i = 0; i + 1 < n; ++i) workers_.emplace_back([this, thread_name = std::string(name)] {
      name_this_thread(thread_name.c_str());
      worker_loop();
    });
  } catch (const std::system_error& e) {
    // The system refused a thread: stop the ones started, so that nothing is left joinable.
    const std::size_t started = workers_.size();
    stop_workers();
    throw std::runtime_error("cpu backend: could not start " + std::to_string(n - 1) + " worker threads (" +
                             std::to_string(started) + " started): " + e.what() + "; ask for fewer with --threads");
  }
}

ThreadPool::~ThreadPool() { stop_workers(); }

void ThreadPool::stop_workers() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (auto& t : workers_) t.join();
  workers_.clear();
}

void ThreadPool::wait_for_workers_outside() const {
  for (int k = 0; inside_.load() != 0; ++k) {
    if (k > 64) std::this_thread::yield();
  }
}

void ThreadPool::parallel_for(std::int64_t begin, std::int64_t end, const std::function<void(std::int64_t)>& fn) {
  if (end <= begin) return;
  if (workers_.empty() || end - begin == 1) {
    for (std::int64_t i = begin; i < end; ++i) fn(i);
    return;
  }
  // Set up (odd generation): workers still inside the previous job leave first.
  generation_.fetch_add(1);
  wait_for_workers_outside();
  job_ = &fn;
  end_ = end;
  chunk_ = std::max<std::int64_t>(1, (end - begin) / (static_cast<std::int64_t>(size()) * 4));
  next_.store(begin);
  {
    std::lock_guard lock(mutex_);
    generation_.fetch_add(1);  // even: ready
  }
  wake_.notify_all();
  // The calling thread works too, then waits only for chunks that workers are running: a worker
  // the scheduler has not run yet finds every chunk taken when it wakes, and nobody waits for it.
  for (std::int64_t a = next_.fetch_add(chunk_); a < end; a = next_.fetch_add(chunk_)) {
    const std::int64_t b = std::min(end, a + chunk_);
    for (std::int64_t i = a; i < b; ++i) fn(i);
  }
  wait_for_workers_outside();
}

void ThreadPool::worker_loop() {
  std::uint64_t seen = 0;
  for (;;) {
    // A frame calls parallel_for dozens of times back to back: spin a little before sleeping, so
    // that the next call finds this worker awake (waking a sleeping thread costs tens of
    // microseconds, more on a virtual machine whose idle core has halted).
    const auto ready = [&] {
      const std::uint64_t g = generation_.load();
      return g != seen && g % 2 == 0;
    };
    const auto spin_until = std::chrono::steady_clock::now() + kSpinBeforeSleep;
    for (int k = 1; !ready() && !stop_.load(std::memory_order_relaxed); ++k) {
      if (k % 64 == 0 && std::chrono::steady_clock::now() >= spin_until) break;
      std::this_thread::yield();
    }
    if (!ready()) {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stop_.load() || ready(); });
    }
    if (stop_.load()) return;
    const std::uint64_t g = generation_.load();
    seen = g;
    if (g % 2 != 0) continue;
    inside_.fetch_add(1);
    if (generation_.load() == g) {  // still this job: its fields are stable while we are inside
      const auto* fn = job_;
      const std::int64_t end = end_, chunk = chunk_;
      for (std::int64_t a = next_.fetch_add(chunk); a < end; a = next_.fetch_add(chunk)) {
        const std::int64_t b = std::min(end, a + chunk);
        for (std::int64_t i = a; i < b; ++i) (*fn)(i);
      }
    }
    inside_.fetch_sub(1);
  }
}

}  // namespace porta::cpu
