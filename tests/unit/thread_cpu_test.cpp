// portaslam run's CPU by thread (apps/portaslam/thread_cpu.hpp): the sums by name between two
// snapshots, and a snapshot of this process naming a thread that worked.
#include "portaslam/thread_cpu.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <thread>

#include "cpu/thread_name.hpp"

namespace porta::app {
namespace {

ThreadCpuSnapshot snapshot_of(std::initializer_list<std::pair<int, ThreadCpuSnapshot::Thread>> threads) {
  ThreadCpuSnapshot s;
  for (const auto& [tid, thread] : threads) s.by_tid[tid] = thread;
  return s;
}

TEST(ThreadCpu, SumsByNameCountsNewThreadsFromZeroAndNamesWhatEndedThreadsSpent) {
  const ThreadCpuSnapshot start = snapshot_of({{1, {"main", 2.0}}, {2, {"pool", 1.0}}, {3, {"pool", 0.5}},
                                               {9, {"reader", 0.25}}});  // 9 ends before `end`
  const ThreadCpuSnapshot end = snapshot_of({{1, {"main", 2.5}}, {2, {"pool", 1.75}}, {3, {"pool", 1.0}},
                                             {4, {"mapping", 3.0}}});  // 4 started meanwhile
  const auto by_thread = thread_cpu_between(start, end, 5.0);
  ASSERT_EQ(by_thread.size(), 4u);
  EXPECT_EQ(by_thread[0].first, "mapping");
  EXPECT_DOUBLE_EQ(by_thread[0].second, 3.0);
  EXPECT_EQ(by_thread[1].first, "pool");
  EXPECT_DOUBLE_EQ(by_thread[1].second, 1.25);  // both pool threads, each from its own start
  EXPECT_EQ(by_thread[2].first, "main");
  EXPECT_DOUBLE_EQ(by_thread[2].second, 0.5);
  EXPECT_EQ(by_thread[3].first, "(ended threads)");
  EXPECT_DOUBLE_EQ(by_thread[3].second, 5.0 - 4.75);
}

TEST(ThreadCpu, ReportsNothingWithoutSnapshotsAndNeverANegativeShare) {
  EXPECT_TRUE(thread_cpu_between({}, {}, 1.0).empty());
  // A tid reused by a new thread with less CPU than the old one had: 0, not negative.
  const auto reused = thread_cpu_between(snapshot_of({{1, {"old", 4.0}}}), snapshot_of({{1, {"new", 1.0}}}), 0.0);
  ASSERT_EQ(reused.size(), 2u);
  EXPECT_DOUBLE_EQ(reused[0].second, 0.0);
  EXPECT_DOUBLE_EQ(reused[1].second, 0.0);
  // A process total below the threads' sum (clock ticks against microseconds): "ended" is 0.
  const auto rounded = thread_cpu_between(snapshot_of({{1, {"main", 1.0}}}), snapshot_of({{1, {"main", 2.0}}}), 0.98);
  ASSERT_EQ(rounded.size(), 2u);
  EXPECT_DOUBLE_EQ(rounded[0].second, 1.0);
  EXPECT_DOUBLE_EQ(rounded[1].second, 0.0);
}

TEST(ThreadCpu, TextAndJsonNameEveryThreadAndTheReading) {
  const std::vector<std::pair<std::string, double>> by_thread{{"porta-mapping", 2.0}, {"quote\"d", 1.0}};
  EXPECT_EQ(thread_cpu_text(by_thread, 0.5, 100.0),
            "host CPU by thread (ms per frame): porta-mapping 20.00, quote\"d 10.00; of all this, reading the images 5.00");
  EXPECT_EQ(thread_cpu_json(by_thread, 0.5), "{\"by_thread_s\": {\"porta-mapping\": 2, \"quote\\\"d\": 1}, \"reading_s\": 0.5}");
  EXPECT_EQ(thread_cpu_text({}, 0.5, 100.0), "");
}

#if defined(__linux__)
TEST(ThreadCpu, SnapshotNamesAThreadAndTheCpuItSpent) {
  std::atomic<bool> ready{false}, done{false};
  double spent = 0.0;
  std::thread worker([&] {
    cpu::name_this_thread("porta-test-burn");
    const double start = this_thread_cpu_seconds();
    volatile double sink = 0.0;
    while (this_thread_cpu_seconds() - start < 0.1) sink = sink + 1.0;  // 100 ms of CPU, however long it takes
    spent = this_thread_cpu_seconds() - start;
    ready = true;
    while (!done) std::this_thread::yield();
  });
  while (!ready) std::this_thread::yield();
  const ThreadCpuSnapshot snapshot = thread_cpu_snapshot();
  done = true;
  worker.join();
  EXPECT_GE(spent, 0.1);
  const auto named = std::find_if(snapshot.by_tid.begin(), snapshot.by_tid.end(),
                                  [](const auto& entry) { return entry.second.name == "porta-test-burn"; });
  ASSERT_NE(named, snapshot.by_tid.end()) << "the named thread is not in /proc/self/task";
  EXPECT_GE(named->second.cpu_s, 0.08);  // /proc counts in clock ticks (10 ms)
}
#endif

}  // namespace
}  // namespace porta::app
