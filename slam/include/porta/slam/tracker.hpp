// Tracking (DESIGN.md §6, after ORB-SLAM2's Tracking, stereo): estimates the pose of every frame
// against the map and decides when to make keyframes.
//
//  1. Initialisation: the first frame with at least settings.min_init_stereo_points stereo points
//     becomes keyframe 0 at the origin, with a map point per stereo point.
//  2. Motion model: the last frame's points projected with a constant-velocity prediction, matched
//     in a window (ORB-SLAM2's rotation-consistency histogram and ratio checks), pose-only
//     optimisation (optim/pose_optimization.hpp). Fallback: the reference keyframe's points projected
//     with the last pose and a wider window.
//  3. Local map: the keyframes covisible with the frame's points and their neighbours; their points
//     projected into the frame and matched on the compute backend (Backend::projection_match), ratio
//     check, then pose-only optimisation again.
//  4. Keyframe decision (ORB-SLAM2's NeedNewKeyFrame incl. close/far stereo points); a new keyframe
//     gets map points for its close stereo points and is handed to local mapping.
// Tracking loss (too few inliers) is reported in the result and never silently continued. A lost
// frame, and every frame after it until one succeeds, tries relocalisation (ORB-SLAM2's: the
// place-recognition database's candidates, EPnP in RANSAC, pose optimisation, 50 inliers), then
// the local map as usual. Relocalisation that keeps failing keeps the state `lost` (each result
// says why); the map is never reset.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "porta/backend.hpp"
#include "porta/slam/frame.hpp"
#include "porta/slam/local_mapper.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/slam_settings.hpp"

namespace porta::slam {

class LoopCloser;

enum class TrackingState { not_initialized, ok, lost };
const char* to_string(TrackingState state);

struct TrackingResult {
  TrackingState state = TrackingState::not_initialized;
  SE3 T_cw = SE3::Identity();        ///< valid when state == ok
  KeyFrame* reference_keyframe = nullptr;
  /// T_cw relative to the reference keyframe's pose as tracking saw it (state == ok), taken under
  /// the same hold of the map's lock as the pose: once tracking lets the lock go, local mapping
  /// may move the keyframe (a local BA written back), and the frame was not tracked against that.
  SE3 T_c_ref = SE3::Identity();
  bool keyframe_inserted = false;
  bool used_motion_model = false;    ///< false: reference-keyframe fallback (or initialisation)
  bool relocalised = false;          ///< the pose came from relocalisation (the frame or the one before was lost, or EPnP against the reference keyframe beat a weak motion-model prediction)
  int matches_motion = 0;            ///< inliers after the first pose optimisation
  int predicted_inliers = -1;        ///< the constant-velocity prediction's inliers (-1: not tried)
  bool motion_hypotheses = false;    ///< the prediction was weak: the last pose and EPnP were tried too
  int last_frame_points = 0;         ///< map points the last frame had (what the motion model can match)
  int mapping_queue = 0;             ///< keyframes waiting for local mapping when the frame was tracked
  int matches_local_map = 0;         ///< inliers after local-map tracking
  std::string lost_reason;           ///< why tracking was lost, for the user
  std::int64_t map_wait_ns = 0;      ///< waiting for the map's lock (held by local mapping or loop closing)
  /// Within steps 1-3 (Tracker::release_map_lock_while_computing): computing without the map's
  /// lock, and waiting to take it back.
  std::int64_t unlocked_ns = 0, relock_wait_ns = 0;
  std::int64_t track_motion_ns = 0;  ///< steps 1-2
  std::int64_t track_local_map_ns = 0;
  std::int64_t keyframe_ns = 0;
};

class Tracker {
 public:
  /// `backend` runs the projection-match kernel, on its queue `projection_queue` (-1: the current
  /// one; System gives it Frontend::spare_queue()); `tables` are the frontend's (level scales);
  /// `loop_closer` (may be null: no relocalisation) holds the place-recognition database.
  Tracker(const SlamSettings& settings, Map& map, LocalMapper& mapper, Backend& backend,
          const FrontendTables& tables, LoopCloser* loop_closer = nullptr, int projection_queue = -1);
  ~Tracker();
  Tracker(const Tracker&) = delete;
  Tracker& operator=(const Tracker&) = delete;

  /// Tracks one frame (its features already converted, FrameFeatures::from_frontend). Takes
  /// Map::mutex itself.
  TrackingResult track(std::uint64_t frame_id, double time_s, std::shared_ptr<const FrameFeatures> features);

  /// On: the map's lock is released while tracking computes on copies of map data (the pose-only
  /// optimisations and the projection matcher), so that local mapping and loop closing can take
  /// it meanwhile; System turns it on in the realtime mode with
  /// SlamSettings::tracking_releases_map_lock. Off (the default): the lock is held
  /// from the start of track() to its end, as in ORB-SLAM2. When a loop correction moved the map
  /// while the lock was released, the step is computed again under the lock. With nothing else
  /// taking the lock, both give the same result.
  void release_map_lock_while_computing(bool on);
  /// Tests: called in every window without the map's lock, after its work.
  void set_unlocked_hook(std::function<void()> hook);

  TrackingState state() const { return state_; }
  /// A map was loaded: the next frame relocalises against it instead of initialising a new map.
  /// `why` goes into the lost reason until then.
  void relocalise_next(const std::string& why);
  const Frame& last_frame() const { return last_frame_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  TrackingState state_ = TrackingState::not_initialized;
  Frame last_frame_;
};

}  // namespace porta::slam
