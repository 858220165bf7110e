// Tracker's state and steps (Tracker::Impl), shared by tracker.cpp (initialisation, the motion
// model, relocalisation, track()) and tracker_local_map.cpp (the local map and keyframes); see
// tracker.hpp. Private to slam/tracking/.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include "frame_search.hpp"
#include "local_points.hpp"
#include "porta/slam/elapsed.hpp"
#include "porta/slam/projection_matcher.hpp"
#include "porta/slam/tracker.hpp"

namespace porta::slam {

// ORB-SLAM2's constants for stereo tracking.
inline constexpr double kMotionWindowPx = 7.0;     // motion-model search window at level 0 (doubled on retry)
inline constexpr int kMotionMinMatches = 20;       // matches needed before optimising the motion-model pose
inline constexpr int kConfidentMotionInliers = 50;  // fewer: also try the last pose and EPnP (no prediction)
inline constexpr double kKeyframeWindowPx = 15.0;  // fallback: wide window, no bag-of-words vocabulary here
inline constexpr int kKeyframeMinMatches = 15;
inline constexpr int kMinPoseInliers = 10;
inline constexpr double kLocalMapWindow = 1.0;  // th of the local-map search (3 after relocalisation)
inline constexpr std::size_t kMaxLocalKeyframes = 80;
inline constexpr std::size_t kCovisiblesPerKeyframe = 10;
inline constexpr std::size_t kRelocalisationNeighbours = 5;
inline constexpr int kMinInliersAfterRelocalisation = 50;  // ORB-SLAM2's bar for frames just relocalised

/// The keyframe itself, or its closest good ancestor when local mapping culled it.
inline KeyFrame* good_or_ancestor(KeyFrame* keyframe) {
  while (keyframe != nullptr && keyframe->bad) keyframe = keyframe->parent;
  return keyframe;
}

struct Tracker::Impl {
  Impl(const SlamSettings& s, Map& m, LocalMapper& lm, Backend& backend, const FrontendTables& tables,
       LoopCloser* lc, int projection_queue)
      : settings(s),
        map(m),
        mapper(lm),
        loop_closer(lc),
        pyramid(tables.settings.levels, tables.settings.scale_factor),
        scales_q16(tables.scales_q16),
        geometry{settings.camera, pyramid, scales_q16},
        matcher(settings.projection_on_backend ? &backend : nullptr, scales_q16, projection_queue) {}

  bool initialize(Frame& frame, TrackingResult& result);
  int match_last_frame_from(Frame& frame, const Frame& last, const SE3& T_cw, double window_px);
  bool track_motion_model(Frame& frame, Frame& last, TrackingResult& result);
  bool track_reference_keyframe(Frame& frame, const Frame& last, TrackingResult& result);
  bool track_local_map(Frame& frame, TrackingResult& result);
  bool relocalise(Frame& frame, TrackingResult& result);
  void update_last_frame(Frame& last) const;
  void update_local_keyframes(Frame& frame);
  int search_local_points(Frame& frame);
  bool need_new_keyframe(const Frame& frame) const;
  KeyFrame* create_keyframe(Frame& frame);
  int optimize_pose(Frame& frame);
  template <class Work>
  bool without_map_lock(Frame& frame, Work&& work);

  const SlamSettings settings;
  Map& map;
  LocalMapper& mapper;
  LoopCloser* loop_closer;  // its database finds relocalisation candidates; null: no relocalisation
  const ScalePyramid pyramid;
  const std::vector<std::int32_t> scales_q16;
  const tracking::SearchGeometry geometry;
  ProjectionMatcher matcher;

  SE3 velocity = SE3::Identity();  // T_cw(k) * T_wc(k-1)
  bool has_velocity = false;
  KeyFrame* reference_keyframe = nullptr;
  std::uint64_t last_keyframe_frame_id = 0;
  std::uint64_t last_relocalisation_frame = 0;
  bool any_relocalisation = false;
  std::uint64_t last_recovery_frame = 0;  // the last relocalisation from lost (not a motion hypothesis)
  bool any_recovery = false;
  // Stereo depths beyond this count as monocular in this frame's pose optimisations: infinite,
  // except on a relocalisation from lost and the keyframe interval after it (track()).
  double stereo_depth_limit = std::numeric_limits<double>::infinity();
  SE3 T_last_ref = SE3::Identity();  // last frame relative to its reference keyframe
  int local_map_inliers = 0;
  std::vector<KeyFrame*> local_keyframes;
  tracking::LocalPoints local_points;  // of local_keyframes
  // search_local_points' buffers, kept across frames.
  std::vector<tracking::ProjectedPoint> projected;
  std::vector<ProjectionQuery> queries;
  std::vector<Descriptor> query_descriptors;
  // While track() runs: the lock it holds, which it may release (release_map_lock_while_computing),
  // and its result, which counts the time without the lock and waiting to take it back.
  std::unique_lock<MapMutex>* map_lock = nullptr;
  TrackingResult* timed = nullptr;
  bool release_map_lock = false;
  bool map_moved = false;  // a loop correction or a local BA moved the map while this frame released the lock
  std::function<void()> unlocked_hook;
  std::uint64_t frame_points_mark = 0;  // MapPoint::tracking_frame_mark of the latest frame
  std::uint64_t keyframe_vote_mark = 0, keyframe_local_mark = 0;  // KeyFrame::tracking_*_mark of the latest frame
  std::string lost_reason;
};

// ---- Work without the map's lock ----------------------------------------------------------------

// Runs `work`, which touches no map object, with the map's lock released when allowed, and takes
// the lock back before local mapping's next long step (Map::lock_first). Returns false when a loop
// correction moved the map meanwhile, or a local bundle adjustment moved the frame's reference
// keyframe: what `work` computed from copies made before is stale, and the frame's pose has been
// moved with its reference keyframe (as update_last_frame moves the last frame), for the caller to
// compute the step again.
template <class Work>
bool Tracker::Impl::without_map_lock(Frame& frame, Work&& work) {
  if (!release_map_lock || map_lock == nullptr || timed == nullptr) {
    work();
    return true;
  }
  const std::uint64_t generation = map.correction_generation;
  KeyFrame* anchor = good_or_ancestor(frame.reference_keyframe);
  const SE3 anchor_T_cw = anchor != nullptr ? anchor->T_cw : SE3::Identity();
  map_lock->unlock();
  const auto start = std::chrono::steady_clock::now();
  work();
  if (unlocked_hook) unlocked_hook();
  timed->unlocked_ns += elapsed_ns(start);
  const auto wait_start = std::chrono::steady_clock::now();
  *map_lock = map.lock_first();
  timed->relock_wait_ns += elapsed_ns(wait_start);
  // A loop correction, or local mapping's BA written back with the frame's keyframe in its window:
  // the copies were of the map before, and the step is computed again from where it is now.
  const bool anchor_moved = anchor != nullptr && anchor->T_cw.matrix() != anchor_T_cw.matrix();
  if (map.correction_generation == generation && !anchor_moved) return true;
  map_moved = true;
  if (anchor != nullptr) frame.T_cw = frame.T_cw * anchor_T_cw.inverse() * anchor->T_cw;
  return false;
}

}  // namespace porta::slam
