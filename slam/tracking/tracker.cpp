// Tracking after ORB-SLAM2's stereo Tracking (written from its description); see tracker.hpp.
//
// One track() call holds Map::mutex from start to end: every step reads or writes map objects, and
// local mapping must not move points under a pose optimisation; with
// release_map_lock_while_computing it lets the lock go while it computes on copies
// (without_map_lock): the pose optimisations and the projection matcher's kernel. Every loop that
// decides something runs over feature indices or id-ordered containers, so the same frames give
// the same bits.
// The state and the steps of the local map and keyframes: tracker_impl.hpp, tracker_local_map.cpp.
#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "porta/slam/loop_closer.hpp"
#include "relocalisation.hpp"
#include "tracker_impl.hpp"

namespace porta::slam {

const char* to_string(TrackingState state) {
  switch (state) {
    case TrackingState::not_initialized:
      return "not initialized";
    case TrackingState::ok:
      return "ok";
    case TrackingState::lost:
      return "lost";
  }
  return "?";
}

namespace {

void check_features(const FrameFeatures& f, int levels) {
  const std::size_t n = f.size();
  auto require = [&](std::size_t size, const char* field) {
    if (size != n) {
      throw std::invalid_argument(std::string("Tracker::track: FrameFeatures::") + field + " has " +
                                  std::to_string(size) + " entries, uv has " + std::to_string(n));
    }
  };
  require(f.level.size(), "level");
  require(f.angle_rad.size(), "angle_rad");
  require(f.descriptors.size(), "descriptors");
  require(f.u_right.size(), "u_right");
  require(f.depth_m.size(), "depth_m");
  if (!f.keypoints.empty()) require(f.keypoints.size(), "keypoints");
  for (std::size_t i = 0; i < n; ++i) {
    if (f.level[i] >= levels) {
      throw std::invalid_argument("Tracker::track: feature " + std::to_string(i) + " is on level " +
                                  std::to_string(f.level[i]) + ", the pyramid has " + std::to_string(levels));
    }
  }
}

}  // namespace

// ---- Initialisation -----------------------------------------------------------------------------

bool Tracker::Impl::initialize(Frame& frame, TrackingResult& result) {
  const FrameFeatures& f = *frame.features;
  int stereo = 0;
  for (std::size_t i = 0; i < f.size(); ++i) stereo += f.has_depth(i) ? 1 : 0;
  if (stereo < settings.min_init_stereo_points) {
    result.lost_reason = "not initialised: frame " + std::to_string(frame.id) + " has " +
                         std::to_string(stereo) +
                         " stereo points, initialisation needs min_init_stereo_points = " +
                         std::to_string(settings.min_init_stereo_points);
    return false;
  }
  frame.T_cw = SE3::Identity();
  frame.has_pose = true;
  KeyFrame* keyframe = map.add_keyframe(frame);
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (!f.has_depth(i)) continue;
    MapPoint* point = map.add_point(frame.unproject_stereo(i, settings.camera), keyframe, frame.id);
    Map::add_observation(point, keyframe, static_cast<int>(i));
    point->update_descriptor();
    point->update_normal_and_depth(pyramid);
    frame.points[i] = point;
  }
  frame.reference_keyframe = keyframe;
  reference_keyframe = keyframe;
  last_keyframe_frame_id = frame.id;
  local_keyframes = {keyframe};
  T_last_ref = SE3::Identity();
  has_velocity = false;
  mapper.insert_keyframe(keyframe);
  result.keyframe_inserted = true;
  return true;
}


// The frame's pose-only optimisation, solved without the lock on a copy of its matches' positions.
int Tracker::Impl::optimize_pose(Frame& frame) {
  tracking::FramePoseProblem problem = tracking::frame_pose_problem(frame, geometry, stereo_depth_limit);
  optim::PoseOptimizationResult solved;
  const auto solve = [&] {
    solved = optim::optimize_pose(geometry.camera, frame.T_cw, problem.observations);
  };
  if (!without_map_lock(frame, solve)) {  // the map moved: again from its new positions, under the lock
    problem = tracking::frame_pose_problem(frame, geometry, stereo_depth_limit);
    solve();
  }
  return tracking::apply_frame_pose(frame, problem, solved);
}

// ---- Motion model and its fallback -------------------------------------------------------------

void Tracker::Impl::update_last_frame(Frame& last) const {
  // Local mapping may have merged or culled points, and moved the reference keyframe (bundle
  // adjustment): follow both.
  for (MapPoint*& point : last.points) {
    while (point != nullptr && point->bad) point = point->replaced_by;
  }
  if (last.reference_keyframe != nullptr && !last.reference_keyframe->bad) {
    last.T_cw = T_last_ref * last.reference_keyframe->T_cw;
  }
}

// Matches with the last frame from the prediction `T_cw`, then the pose optimised on them: the
// inliers, or -1 when too few matches were found. The window is doubled once if needed.
int Tracker::Impl::match_last_frame_from(Frame& frame, const Frame& last, const SE3& T_cw, double window_px) {
  frame.T_cw = T_cw;
  std::fill(frame.points.begin(), frame.points.end(), nullptr);
  int matches = tracking::search_last_frame(frame, last, window_px, geometry);
  if (matches < kMotionMinMatches) {
    std::fill(frame.points.begin(), frame.points.end(), nullptr);
    matches = tracking::search_last_frame(frame, last, 2.0 * window_px, geometry);
  }
  if (matches < kMotionMinMatches) {
    lost_reason = "motion model: " + std::to_string(matches) + " matches with the last frame (need " +
                  std::to_string(kMotionMinMatches) + ")";
    return -1;
  }
  optimize_pose(frame);
  return tracking::discard_outliers(frame);
}

bool Tracker::Impl::track_motion_model(Frame& frame, Frame& last, TrackingResult& result) {
  result.matches_motion = match_last_frame_from(frame, last, velocity * last.T_cw, kMotionWindowPx);
  result.predicted_inliers = result.matches_motion;
  if (result.matches_motion < kConfidentMotionInliers) {
    result.motion_hypotheses = true;
    // Few inliers: the motion changed at once (a turn that starts or ends, a jolt), and the
    // constant-velocity prediction, off by degrees, matched the wrong features (on repeated
    // façades, consistently wrong ones). Two more hypotheses: the last pose as the prediction (no
    // motion) with the wide window, and no prediction at all, descriptor matching with EPnP
    // against the reference keyframe (relocalisation's test). The one with most inliers stays.
    // discard_outliers leaves no outlier flag set: pose and points are all a hypothesis is.
    // When EPnP wins, the frame was relocalised (against the reference keyframe) and says so, as
    // after a loss: the user learns that the motion model failed, and the stricter inlier bar of
    // the frames after a relocalisation applies.
    const int predicted = result.matches_motion;
    SE3 best_T_cw = frame.T_cw;
    std::vector<MapPoint*> best_points = frame.points;
    const std::string first_reason = lost_reason;
    bool by_pnp = false;
    const auto keep_if_better = [&](int inliers, bool pnp) {
      if (inliers > result.matches_motion) {
        result.matches_motion = inliers;
        best_T_cw = frame.T_cw;
        best_points = frame.points;
        by_pnp = pnp;
      }
    };
    keep_if_better(match_last_frame_from(frame, last, last.T_cw, 2.0 * kMotionWindowPx), false);
    KeyFrame* reference = good_or_ancestor(reference_keyframe);
    if (reference != nullptr) {
      frame.T_cw = last.T_cw;
      const tracking::Relocalisation found = tracking::relocalise(frame, {reference}, geometry, stereo_depth_limit);
      if (found.ok) keep_if_better(found.inliers, true);
    }
    frame.T_cw = best_T_cw;
    frame.points = best_points;
    lost_reason = first_reason;
    if (by_pnp) {
      result.relocalised = true;
      result.lost_reason = "relocalised at frame " + std::to_string(frame.id) + " against keyframe " +
                           std::to_string(reference->id) + " (" + std::to_string(result.matches_motion) +
                           " inliers) after: motion model: the constant-velocity prediction had " +
                           std::to_string(std::max(predicted, 0)) + " inliers";
    }
  }
  if (result.matches_motion < 0) return false;
  if (result.matches_motion < kMinPoseInliers) {
    lost_reason = "motion model: " + std::to_string(result.matches_motion) +
                  " inliers after pose optimisation (need " + std::to_string(kMinPoseInliers) + ")";
    return false;
  }
  return true;
}

bool Tracker::Impl::track_reference_keyframe(Frame& frame, const Frame& last, TrackingResult& result) {
  KeyFrame* keyframe = good_or_ancestor(reference_keyframe);
  if (keyframe == nullptr) {
    lost_reason += std::string(lost_reason.empty() ? "" : "; ") + "no reference keyframe";
    return false;
  }
  frame.T_cw = last.T_cw;
  std::fill(frame.points.begin(), frame.points.end(), nullptr);
  const int matches = tracking::search_keyframe(frame, *keyframe, kKeyframeWindowPx, geometry);
  const std::string what = "reference keyframe " + std::to_string(keyframe->id) + ": ";
  if (matches < kKeyframeMinMatches) {
    lost_reason += (lost_reason.empty() ? "" : "; ") + what + std::to_string(matches) + " matches (need " +
                   std::to_string(kKeyframeMinMatches) + ")";
    return false;
  }
  optimize_pose(frame);
  result.matches_motion = tracking::discard_outliers(frame);
  if (result.matches_motion < kMinPoseInliers) {
    lost_reason += (lost_reason.empty() ? "" : "; ") + what + std::to_string(result.matches_motion) +
                   " inliers after pose optimisation (need " + std::to_string(kMinPoseInliers) + ")";
    return false;
  }
  return true;
}


// ---- Relocalisation -----------------------------------------------------------------------------

bool Tracker::Impl::relocalise(Frame& frame, TrackingResult& result) {
  const std::string before = lost_reason.empty() ? "" : lost_reason + "; ";
  if (loop_closer == nullptr) {
    lost_reason = before + "relocalisation is off (no place-recognition database)";
    return false;
  }
  std::fill(frame.points.begin(), frame.points.end(), nullptr);
  // The last reference keyframe and its best neighbours come first: after fast motion or a weak
  // frame the camera is still near them, and descriptor matching with EPnP needs no pose prior,
  // unlike the windowed searches of the motion model and the reference-keyframe step.
  std::vector<KeyFrame*> candidates;
  if (KeyFrame* reference = good_or_ancestor(reference_keyframe); reference != nullptr) {
    candidates.push_back(reference);
    for (KeyFrame* k : reference->best_covisibles(kRelocalisationNeighbours)) candidates.push_back(k);
  }
  for (KeyFrame* k : loop_closer->relocalisation_candidates(*frame.features)) {
    if (std::find(candidates.begin(), candidates.end(), k) == candidates.end()) candidates.push_back(k);
  }
  stereo_depth_limit = settings.close_depth_m();  // track(): why
  const tracking::Relocalisation found = tracking::relocalise(frame, candidates, geometry, stereo_depth_limit);
  if (!found.ok) {
    lost_reason = before + "relocalisation: " + found.reason;
    return false;
  }
  result.matches_motion = found.inliers;
  // Said even on success: the user learns that (and why) tracking was lost for a moment.
  result.lost_reason = "relocalised at frame " + std::to_string(frame.id) + " against keyframe " +
                       std::to_string(found.keyframe->id) + " (" + std::to_string(found.inliers) + " inliers)" +
                       (lost_reason.empty() ? std::string() : " after: " + lost_reason);
  reference_keyframe = found.keyframe;
  frame.reference_keyframe = found.keyframe;
  has_velocity = false;
  last_recovery_frame = frame.id;
  any_recovery = true;
  return true;
}

// ---- Tracker ------------------------------------------------------------------------------------

Tracker::Tracker(const SlamSettings& settings, Map& map, LocalMapper& mapper, Backend& backend,
                 const FrontendTables& tables, LoopCloser* loop_closer, int projection_queue)
    : impl_(std::make_unique<Impl>(settings, map, mapper, backend, tables, loop_closer, projection_queue)) {
  settings.validate();
  if (tables.scales_q16.size() != static_cast<std::size_t>(tables.settings.levels)) {
    throw std::invalid_argument("Tracker: the frontend tables have " +
                                std::to_string(tables.scales_q16.size()) + " level scales for " +
                                std::to_string(tables.settings.levels) + " levels");
  }
}

Tracker::~Tracker() = default;

void Tracker::release_map_lock_while_computing(bool on) { impl_->release_map_lock = on; }

void Tracker::set_unlocked_hook(std::function<void()> hook) { impl_->unlocked_hook = std::move(hook); }

void Tracker::relocalise_next(const std::string& why) {
  state_ = TrackingState::lost;
  impl_->lost_reason = why;
}

TrackingResult Tracker::track(std::uint64_t frame_id, double time_s,
                              std::shared_ptr<const FrameFeatures> features) {
  if (!features)
    throw std::invalid_argument("Tracker::track: frame " + std::to_string(frame_id) + " has no features");
  Impl& t = *impl_;
  check_features(*features, t.pyramid.levels);
  TrackingResult result;
  Frame frame(frame_id, time_s, std::move(features), t.settings.camera);
  const auto wait_start = std::chrono::steady_clock::now();
  std::unique_lock<MapMutex> lock = t.map.lock_first();  // local mapping's fusion yields to it
  result.map_wait_ns = elapsed_ns(wait_start);
  const auto start = std::chrono::steady_clock::now();
  // Impl::without_map_lock may release `lock` and take it back, and counts the time in `result`.
  struct LockScope {
    Impl& t;
    LockScope(Impl& impl, TrackingResult& result, std::unique_lock<MapMutex>& lock) : t(impl) {
      t.map_lock = &lock;
      t.timed = &result;
      t.map_moved = false;
    }
    ~LockScope() {
      t.map_lock = nullptr;
      t.timed = nullptr;
    }
    LockScope(const LockScope&) = delete;
    LockScope& operator=(const LockScope&) = delete;
  } lock_scope(t, result, lock);

  if (state_ == TrackingState::not_initialized) {
    if (!t.initialize(frame, result)) return result;
    state_ = TrackingState::ok;
    result.lost_reason.clear();
    result.state = TrackingState::ok;
    result.T_cw = frame.T_cw;
    result.reference_keyframe = t.reference_keyframe;
    result.T_c_ref = t.T_last_ref;
    result.track_motion_ns = elapsed_ns(start);
    last_frame_ = std::move(frame);
    return result;
  }

  // Lost now, or still lost: the message says which, where and why, relocalisation included.
  const bool was_lost = state_ == TrackingState::lost;
  auto lose = [&](const char* step) {
    state_ = TrackingState::lost;
    t.lost_reason = (was_lost ? "still lost at frame " : "tracking lost at frame ") + std::to_string(frame_id) +
                    " (" + step + "): " + t.lost_reason;
    result.state = TrackingState::lost;
    result.lost_reason = t.lost_reason;
    return result;
  };

  // 1-2: motion model, else the reference keyframe; lost: relocalisation.
  t.update_last_frame(last_frame_);
  result.last_frame_points = static_cast<int>(
      std::count_if(last_frame_.points.begin(), last_frame_.points.end(), [](const MapPoint* p) { return p != nullptr; }));
  result.mapping_queue = static_cast<int>(t.mapper.queued_keyframes());
  frame.reference_keyframe = t.reference_keyframe;
  t.lost_reason.clear();
  // A camera relocalised from lost sees the map from where the map was not built (a covered lens
  // lifted 12 m before the loop's start, a kidnap). There a far point's stereo depth disagrees with
  // its map position by more than its pixel noise allows: measured on the covered-lens street loop,
  // it pulled the relocalised pose 5.7 cm back along the optical axis, 0.38 m at 640x194. So on
  // that frame (Impl::relocalise sets it) and for the keyframe interval after it, stereo depths
  // beyond th_depth * baseline (ORB-SLAM2's close/far split) count as monocular observations. In
  // continuous tracking the map's far points were made from nearby views and stereo helps
  // (tracking all frames this way: street-loop RPE 0.0093 -> 0.0105 m), so it stays on there.
  t.stereo_depth_limit =
      t.any_recovery &&
              frame.id < t.last_recovery_frame + static_cast<std::uint64_t>(t.settings.max_frames_between_keyframes)
          ? t.settings.close_depth_m()
          : std::numeric_limits<double>::infinity();
  bool ok = false;
  if (!was_lost) {
    if (t.has_velocity) {
      ok = t.track_motion_model(frame, last_frame_, result);
      result.used_motion_model = ok && !result.relocalised;
    }
    if (!ok) ok = t.track_reference_keyframe(frame, last_frame_, result);
  }
  if (!ok) {
    ok = t.relocalise(frame, result);
    result.relocalised = ok;
  }
  result.track_motion_ns = elapsed_ns(start);
  if (!ok) return lose(was_lost ? "relocalisation" : "motion model, reference keyframe and relocalisation");

  // 3: local map.
  const auto local_start = std::chrono::steady_clock::now();
  ok = t.track_local_map(frame, result);
  result.track_local_map_ns = elapsed_ns(local_start);
  if (!ok) return lose("local map");
  // Right after a relocalisation a wrong pose is the likeliest: ORB-SLAM2 asks for 50 local-map
  // inliers for a while (one keyframe interval), not 30.
  if (result.relocalised) {
    t.last_relocalisation_frame = frame.id;
    t.any_relocalisation = true;
  }
  if (t.any_relocalisation &&
      frame.id < t.last_relocalisation_frame + static_cast<std::uint64_t>(t.settings.max_frames_between_keyframes) &&
      result.matches_local_map < kMinInliersAfterRelocalisation) {
    t.lost_reason = "local map: " + std::to_string(result.matches_local_map) + " inliers within " +
                    std::to_string(t.settings.max_frames_between_keyframes) + " frames of a relocalisation (need " +
                    std::to_string(kMinInliersAfterRelocalisation) + ")";
    return lose("local map after relocalisation");
  }
  // A velocity needs two consecutive tracked frames (a frame relocalised after its predecessor was
  // tracked has one: the motion model failed, not the previous pose).
  const bool had_last_pose = !was_lost;
  frame.has_pose = true;
  if (t.map_moved) t.update_last_frame(last_frame_);  // the velocity between poses of the moved map
  t.velocity = had_last_pose ? frame.T_cw * last_frame_.T_cw.inverse() : SE3::Identity();
  t.has_velocity = had_last_pose;

  // 4: keyframe decision.
  const auto keyframe_start = std::chrono::steady_clock::now();
  if (!t.settings.localization_only && t.need_new_keyframe(frame)) {
    t.create_keyframe(frame);
    result.keyframe_inserted = true;
  }
  // Outliers may go to a new keyframe (bundle adjustment decides), never to the next frame's search.
  for (std::size_t i = 0; i < frame.points.size(); ++i) {
    if (frame.outlier[i]) {
      frame.points[i] = nullptr;
      frame.outlier[i] = false;
    }
  }
  result.keyframe_ns = elapsed_ns(keyframe_start);

  KeyFrame* reference = good_or_ancestor(frame.reference_keyframe);
  frame.reference_keyframe = reference;
  t.T_last_ref = reference != nullptr ? frame.T_cw * reference->T_cw.inverse() : SE3::Identity();
  state_ = TrackingState::ok;
  result.state = TrackingState::ok;
  result.T_cw = frame.T_cw;
  result.reference_keyframe = reference;
  result.T_c_ref = t.T_last_ref;
  last_frame_ = std::move(frame);
  return result;
}

}  // namespace porta::slam
