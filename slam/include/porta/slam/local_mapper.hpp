// Local mapping (DESIGN.md §6, after ORB-SLAM2's LocalMapping): takes the keyframes tracking
// inserts and, for each: links its map points, culls recent bad points, creates new points by
// triangulation with covisible keyframes, fuses duplicates with the neighbours, runs local bundle
// adjustment (optim/local_bundle_adjustment.hpp) and culls redundant keyframes.
//
// It runs either in its own thread (RunMode::realtime: start()/stop()) or called by the pipeline
// (RunMode::deterministic: process_all() after each keyframe). All map access follows the locking
// scheme of map.hpp (Map::mutex).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "porta/slam/frame.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/slam_settings.hpp"

namespace porta::cpu {
class ThreadPool;
}

namespace porta::slam {

/// Time spent per keyframe in each step (nanoseconds; pauses for tracking excluded), for the
/// end-of-run statistics.
struct MappingTimes {
  std::uint64_t keyframe_id = 0;
  std::size_t queued = 0;           ///< keyframes waiting behind this one when it was taken
  std::int64_t interval_ns = 0;     ///< between the last two keyframes inserted when it was taken (0: none yet)
  bool spread = false;              ///< linking, triangulation, fusion and BA ran on the mapping pool
  std::int64_t process_ns = 0;      ///< link points, update connections
  std::int64_t cull_points_ns = 0;
  std::int64_t triangulate_ns = 0;
  std::int64_t fuse_ns = 0;
  std::int64_t bundle_adjustment_ns = 0;
  std::int64_t cull_keyframes_ns = 0;
  std::int64_t total_ns = 0;
  /// Of total_ns, the mapping thread's waits to take Map::mutex (held by tracking for its frame,
  /// or by loop closing); the pool's workers take no lock.
  std::int64_t lock_wait_ns = 0;
  bool bundle_adjustment_ran = false;     ///< local BA ran (not skipped: keyframes waiting)
  int bundle_adjustment_iterations = 0;   ///< its Levenberg-Marquardt iterations, both stages
};

class LocalMapper {
 public:
  LocalMapper(const SlamSettings& settings, Map& map);
  ~LocalMapper();  ///< stops the thread if running
  LocalMapper(const LocalMapper&) = delete;
  LocalMapper& operator=(const LocalMapper&) = delete;

  /// Called with each keyframe once it is processed, in the mapping thread (realtime) or the
  /// caller's (deterministic), without any lock held: the pipeline hands it to loop closing.
  void set_keyframe_processed(std::function<void(KeyFrame*)> callback) { keyframe_processed_ = std::move(callback); }

  /// Queues a keyframe made by tracking (thread-safe; does not take Map::mutex). Interrupts a
  /// running bundle adjustment so that the new keyframe is processed soon (realtime mode).
  void insert_keyframe(KeyFrame* keyframe);
  /// True when the mapper is idle and accepts keyframes (ORB-SLAM2's AcceptKeyFrames).
  bool accepts_keyframes() const;
  std::size_t queued_keyframes() const;
  /// Blocks while `limit` or more keyframes are queued (realtime mode; returns at once when the
  /// thread is not running or is stopping).
  void wait_while_queued(std::size_t limit);
  /// Asks a running bundle adjustment to stop at its next iteration.
  void interrupt_bundle_adjustment();

  /// Deterministic mode: processes every queued keyframe in the calling thread, then returns.
  void process_all();
  /// Realtime mode: a thread that processes keyframes as they arrive.
  void start();
  /// Processes what is queued, then joins the thread.
  void stop();

  /// Realtime mode: the tracking thread calls these around each frame. While a frame is being
  /// tracked the mapping thread waits at its next pause point (between steps, between neighbour
  /// keyframes of the triangulation, between bundle-adjustment iterations), unless keyframes are
  /// queued (mapping is behind, so it keeps working), when settings.mapping_yields_to_tracking.
  /// On a machine whose cores share execution units this keeps tracking's latency that of an idle
  /// machine; mapping uses the time between frames.
  void tracking_started();
  void tracking_finished();

  /// One entry per processed keyframe (read after stop() or from the deterministic pipeline).
  const std::vector<MappingTimes>& times() const { return times_; }
  /// Points created by triangulation / merged by fusion / culled as recent points, and keyframes
  /// culled, over the run (read like times()).
  std::uint64_t points_triangulated() const { return points_triangulated_; }
  std::uint64_t points_fused() const { return points_fused_; }
  std::uint64_t points_culled() const { return points_culled_; }
  std::uint64_t keyframes_culled() const { return keyframes_culled_; }

 private:
  void process(KeyFrame* keyframe);
  void thread_main();
  /// In the mapping thread, without Map::mutex held: waits while a frame is being tracked (see
  /// tracking_started()).
  void pause_point();
  /// Takes the oldest queued keyframe (nullptr: none) and clears the bundle-adjustment abort flag.
  KeyFrame* pop_keyframe();
  /// Whether this keyframe's linking, triangulation, fusion and bundle adjustment use the pool:
  /// always in the deterministic mode, in the realtime one while mapping is slower than keyframes
  /// arrive. Their results are the same either way.
  bool spread_over_pool() const;

  const SlamSettings settings_;
  const ScalePyramid pyramid_;
  Map& map_;
  mutable std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::condition_variable dequeued_cv_;  ///< a keyframe left the queue (wait_while_queued)
  std::deque<KeyFrame*> queue_;
  std::atomic<bool> idle_{true};
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> abort_ba_{false};
  std::condition_variable tracking_cv_;
  bool tracking_busy_ = false;  ///< under queue_mutex_
  std::int64_t paused_ns_ = 0;  ///< time pause_point() waited (mapping thread only)
  std::thread thread_;
  bool realtime_ = false;  ///< set before the thread starts, cleared after it joins
  std::unique_ptr<cpu::ThreadPool> pool_;  ///< settings.resolved_mapping_threads() > 1 only
  // Under queue_mutex_: steady-clock time of the last insert_keyframe(), the interval before it,
  // and the wall time the last processed keyframe took.
  std::int64_t last_insert_ns_ = 0;
  std::int64_t keyframe_interval_ns_ = 0;
  std::int64_t last_mapping_ns_ = 0;
  int keyframes_without_ba_ = 0;  ///< processed since local BA last ran (mapping thread only)
  std::function<void(KeyFrame*)> keyframe_processed_;
  std::vector<MapPoint*> recent_points_;  ///< points created by the last keyframes, checked by culling
  std::vector<MappingTimes> times_;
  std::uint64_t points_triangulated_ = 0;
  std::uint64_t points_fused_ = 0;
  std::uint64_t points_culled_ = 0;
  std::uint64_t keyframes_culled_ = 0;
};

}  // namespace porta::slam
