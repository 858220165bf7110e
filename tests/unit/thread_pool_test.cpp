// The cpu backend's thread pool: every index of every parallel_for runs exactly once, before the
// call returns, however many threads, however short the calls and however late a worker wakes.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <memory>
#include <thread>
#include <vector>

#include "cpu/thread_pool.hpp"

namespace porta::cpu {
namespace {

/// Runs parallel_for over [begin, end) and checks each index ran once and nothing outside did.
void expect_each_index_once(ThreadPool& pool, std::int64_t begin, std::int64_t end) {
  const std::int64_t n = end > begin ? end - begin : 0;
  auto counts = std::make_unique<std::atomic<int>[]>(static_cast<std::size_t>(n) + 1);
  std::atomic<int> outside{0};
  pool.parallel_for(begin, end, [&](std::int64_t i) {
    if (i < begin || i >= end) {
      outside.fetch_add(1);
      return;
    }
    counts[static_cast<std::size_t>(i - begin)].fetch_add(1);
  });
  // Everything is visible once parallel_for has returned.
  ASSERT_EQ(outside.load(), 0) << "[" << begin << ", " << end << ")";
  for (std::int64_t i = 0; i < n; ++i) {
    ASSERT_EQ(counts[static_cast<std::size_t>(i)].load(), 1) << "index " << begin + i << " of [" << begin << ", " << end << ")";
  }
}

TEST(ThreadPool, EveryIndexOnceForManySizesAndThreadCounts) {
  for (const int threads : {1, 2, 3, 8, 16}) {
    ThreadPool pool(threads);
    EXPECT_EQ(pool.size(), threads);
    for (const std::int64_t n : {0, 1, 2, 3, 7, 64, 65, 1000, 4097}) expect_each_index_once(pool, 5, 5 + n);
    expect_each_index_once(pool, 10, 3);  // empty range
  }
}

TEST(ThreadPool, ThousandsOfShortCallsBackToBack) {
  // The pattern of a frame: many small loops in a row, workers spinning or waking between them.
  ThreadPool pool(4);
  std::int64_t total = 0;
  for (int call = 0; call < 5000; ++call) {
    std::atomic<std::int64_t> sum{0};
    const std::int64_t n = 1 + call % 37;
    pool.parallel_for(0, n, [&](std::int64_t i) { sum.fetch_add(i + 1); });
    ASSERT_EQ(sum.load(), n * (n + 1) / 2) << "call " << call;
    total += sum.load();
  }
  EXPECT_GT(total, 0);
}

TEST(ThreadPool, CallsAfterTheWorkersFellAsleep) {
  ThreadPool pool(3);
  for (int round = 0; round < 5; ++round) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // longer than the spin
    expect_each_index_once(pool, 0, 500);
  }
}

TEST(ThreadPool, SlowIndicesDoNotLetTheCallReturnEarly) {
  ThreadPool pool(4);
  std::atomic<int> done{0};
  pool.parallel_for(0, 16, [&](std::int64_t i) {
    if (i % 5 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(3));
    done.fetch_add(1);
  });
  EXPECT_EQ(done.load(), 16);
}

TEST(ThreadPool, CreatedAndDestroyedRepeatedly) {
  for (int i = 0; i < 50; ++i) {
    ThreadPool pool(1 + i % 5);
    if (i % 2 == 0) expect_each_index_once(pool, 0, 100);
  }
}

TEST(ThreadPool, BadThreadCountsAndNamesAreClearErrors) {
  const auto message_of = [](auto&& make) {
    try {
      make();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message_of([] { ThreadPool pool(-1); }).find("threads must be in [0, 1024]"), std::string::npos);
  EXPECT_NE(message_of([] { ThreadPool pool(1025); }).find("got 1025"), std::string::npos);
  EXPECT_NE(message_of([] { ThreadPool pool(2, nullptr); }).find("needs a name for its workers, got none"),
            std::string::npos);
  EXPECT_NE(message_of([] { ThreadPool pool(2, ""); }).find("got an empty one"), std::string::npos);
}

#if defined(__linux__)
// The workers carry the pool's name (cut to Linux's 15 characters: a longer one would be refused
// by the kernel and leave them unnamed), so that `portaslam run`'s CPU by thread can tell them apart.
TEST(ThreadPool, WorkersCarryThePoolsNameCutTo15Characters) {
  ThreadPool pool(3, "porta-test-pool-with-a-long-name");
  const auto named = [] {
    int n = 0;
    for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
      std::ifstream comm(task.path() / "comm");
      std::string name;
      if (std::getline(comm, name) && name == "porta-test-pool") ++n;
    }
    return n;
  };
  // A worker names itself when it starts, which may come after the constructor returns: wait for
  // it (a state, not a speed; the deadline only stops a broken build from hanging).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (named() < 2 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(named(), 2);  // the caller is the third thread of the pool
}
#endif

}  // namespace
}  // namespace porta::cpu
