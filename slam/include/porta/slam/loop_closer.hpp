// Loop closing (DESIGN.md §6, after ORB-SLAM2's LoopClosing, stereo): every keyframe local mapping
// has processed goes into the place-recognition database (place_recognition.hpp) and is checked
// for a loop:
//
//  1. Detection: the keyframes the database scores at least as high as the least similar of the
//     keyframe's covisible neighbours, not connected to it, with 80 % of the best candidate's
//     matches; scores accumulated over each candidate's 10 best covisibles, groups within 75 % of
//     the best kept. A candidate is accepted when its covisible group overlaps a group accepted
//     for each of the 3 previous keyframes (ORB-SLAM2's consistency test).
//  2. Verification: descriptor matches between the keyframe's map points and the candidate's,
//     RANSAC over 3-D/3-D pairs for the rigid motion (SE(3): stereo observes the scale), then the
//     points of the candidate and its neighbours projected with that motion and the keyframe's pose
//     optimised against them: at least 40 inliers.
//  3. Correction: the keyframe and its neighbours move by the correction, their points with them;
//     the loop's points replace the duplicates; the essential graph (spanning tree, loop edges,
//     covisibility >= 100, the new loop links) is optimised (optim/pose_graph.hpp) with the loop
//     keyframe fixed; every point follows its reference keyframe.
//  4. Global bundle adjustment over the whole map, in a thread of its own in the realtime mode
//     (stopped by the next loop); its result is merged with what mapping added meanwhile (new
//     keyframes follow their spanning-tree parent, new points their reference keyframe).
//
// Relocalisation (tracking) queries the same database through relocalisation_candidates().
//
// Threads and locks: a realtime LoopCloser runs one loop-closing thread (and the global BA thread).
// A correction holds Map::mutex from start to end, so tracking and mapping see the map before or
// after it, never half-corrected; work done on copies meanwhile (local and global BA) is discarded
// through Map::correction_generation. The database has its own mutex, always taken after
// Map::mutex, never before; the database query and a candidate's descriptor matching hold only
// it (they read the keyframes' immutable features), not Map::mutex. In the deterministic mode
// process_all() does everything in the caller's thread, so the same keyframes give the same bytes.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "porta/slam/frame.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/place_recognition.hpp"
#include "porta/slam/slam_settings.hpp"

namespace porta::slam {

/// One loop the detector accepted (closed or rejected by verification).
struct LoopEvent {
  std::uint64_t keyframe = 0, loop_keyframe = 0;  ///< keyframe ids
  std::uint64_t frame = 0, loop_frame = 0;        ///< frame ids of the two keyframes
  int matches = 0;        ///< descriptor matches with the candidate
  int ransac_inliers = 0;
  int inliers = 0;        ///< after the guided search and the pose optimisation
  bool closed = false;
  std::string rejected;   ///< why verification refused it (empty when closed)
  double correction_m = 0.0;  ///< how far the correction moved the keyframe (metres)
  std::int64_t verify_ns = 0, correct_ns = 0;
};

/// Per processed keyframe: database query and consistency test.
struct LoopTimes {
  std::int64_t detect_ns = 0;
  std::int64_t verify_ns = 0;
  std::int64_t correct_ns = 0;
};

struct GlobalBaRun {
  std::uint64_t after_loop_keyframe = 0;
  std::size_t keyframes = 0, points = 0;
  int iterations = 0;  ///< Levenberg-Marquardt iterations run (at most 30: global_bundle_adjustment.cpp)
  std::int64_t time_ns = 0;
  bool applied = false;  ///< false: stopped by another loop or the end of the run
};

class LoopCloser {
 public:
  /// `settings.loop_closing` says whether loops are searched; the database is always kept (for
  /// relocalisation).
  LoopCloser(const SlamSettings& settings, Map& map);
  ~LoopCloser();  ///< stops the threads
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  /// Queues a keyframe that local mapping finished (thread-safe; does not take Map::mutex).
  void insert_keyframe(KeyFrame* keyframe);
  /// Deterministic mode: processes the queue in the calling thread, global BA included.
  void process_all();
  /// Realtime mode.
  void start();
  /// Processes what is queued, waits for a running global BA, joins the threads.
  void stop();
  /// Realtime mode: true while a loop correction or global BA is running or keyframes wait.
  bool busy() const;

  /// Keyframes that may show what `features` sees, best first (ORB-SLAM2's
  /// DetectRelocalizationCandidates: scored by the database, accumulated over covisible groups,
  /// groups within 75 % of the best). The caller holds Map::mutex.
  std::vector<KeyFrame*> relocalisation_candidates(const FrameFeatures& features);

  /// Replaces the database (a loaded map), before any keyframe is queued. Takes Map::mutex.
  void set_database(PlaceDatabase database);
  /// The database as bytes for a map file (takes the database lock).
  std::vector<std::uint8_t> serialize_database() const;

  // Statistics (read after stop(), or in the deterministic mode).
  const std::vector<LoopEvent>& loops() const { return loops_; }
  const std::vector<LoopTimes>& times() const { return times_; }
  const std::vector<GlobalBaRun>& global_ba_runs() const { return global_ba_runs_; }
  /// Loops closed so far (thread-safe: the progress line reads it while the threads run).
  std::size_t loops_closed() const { return closed_count_; }

 private:
  struct Impl;
  void thread_main();
  void process(KeyFrame* keyframe);
  void run_global_ba(std::uint64_t loop_keyframe, std::uint64_t generation);

  const SlamSettings settings_;
  Map& map_;
  std::unique_ptr<Impl> impl_;
  mutable std::mutex database_mutex_;  ///< after Map::mutex, never before
  mutable std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<KeyFrame*> queue_;
  bool stop_requested_ = false;
  bool working_ = false;
  std::thread thread_;
  std::thread global_ba_thread_;
  std::atomic<bool> global_ba_stop_{false};
  std::atomic<bool> global_ba_running_{false};
  std::atomic<std::size_t> closed_count_{0};
  std::vector<LoopEvent> loops_;
  std::vector<LoopTimes> times_;
  std::vector<GlobalBaRun> global_ba_runs_;  ///< under queue_mutex_ while the threads run
};

}  // namespace porta::slam
