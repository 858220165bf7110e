// Tracking after ORB-SLAM2's stereo Tracking (written from its description); see tracker.hpp.
//
// One track() call holds Map::mutex from start to end: every step reads or writes map objects, and
// local mapping must not move points under a pose optimisation; with
// release_map_lock_while_computing it lets the lock go while it computes on copies
// (without_map_lock): the pose optimisations and the projection matcher's kernel. Every loop that
// decides something runs over feature indices or id-ordered containers, so the same frames give
// the same bits.
#include "porta/slam/tracker.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "frame_search.hpp"
#include "porta/slam/elapsed.hpp"
#include "porta/slam/loop_closer.hpp"
#include "relocalisation.hpp"
#include "porta/slam/projection_matcher.hpp"

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

// ORB-SLAM2's constants for stereo tracking.
constexpr double kMotionWindowPx = 7.0;     // motion-model search window at level 0 (doubled on retry)
constexpr int kMotionMinMatches = 20;       // matches needed before optimising the motion-model pose
constexpr int kConfidentMotionInliers = 50;  // fewer: also try the last pose and EPnP (no prediction)
constexpr double kKeyframeWindowPx = 15.0;  // fallback: wide window, no bag-of-words vocabulary here
constexpr int kKeyframeMinMatches = 15;
constexpr int kMinPoseInliers = 10;
constexpr double kLocalMapWindow = 1.0;  // th of the local-map search (3 after relocalisation)
constexpr std::size_t kMaxLocalKeyframes = 80;
constexpr std::size_t kCovisiblesPerKeyframe = 10;
constexpr std::size_t kRelocalisationNeighbours = 5;
constexpr int kMinInliersAfterRelocalisation = 50;  // ORB-SLAM2's bar for frames just relocalised  // tried first when tracking was just lost

/// The keyframe itself, or its closest good ancestor when local mapping culled it.
KeyFrame* good_or_ancestor(KeyFrame* keyframe) {
  while (keyframe != nullptr && keyframe->bad) keyframe = keyframe->parent;
  return keyframe;
}

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
  // search_local_points' buffers, kept across frames.
  std::vector<tracking::ProjectedPoint> projected;
  std::vector<ProjectionQuery> queries;
  std::vector<Descriptor> query_descriptors;
  // While track() runs: the lock it holds, which it may release (release_map_lock_while_computing),
  // and its result, which counts the time without the lock and waiting to take it back.
  std::unique_lock<std::mutex>* map_lock = nullptr;
  TrackingResult* timed = nullptr;
  bool release_map_lock = false;
  bool map_moved = false;  // a loop correction moved the map while this frame released the lock
  std::function<void()> unlocked_hook;
  std::uint64_t local_points_mark = 0, frame_points_mark = 0;  // MapPoint::tracking_*_mark of the latest build and frame
  std::uint64_t keyframe_vote_mark = 0, keyframe_local_mark = 0;  // KeyFrame::tracking_*_mark of the latest frame
  std::string lost_reason;
};

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

// ---- Work without the map's lock ----------------------------------------------------------------

// Runs `work`, which touches no map object, with the map's lock released when allowed, and takes
// the lock back before local mapping's next long step (Map::lock_first). Returns false when a loop
// correction moved the map meanwhile: what `work` computed from copies made before is stale, and
// the frame's pose has been moved with its reference keyframe (as update_last_frame moves the last
// frame), for the caller to compute the step again.
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
  if (map.correction_generation == generation) return true;
  map_moved = true;
  if (anchor != nullptr) frame.T_cw = frame.T_cw * anchor_T_cw.inverse() * anchor->T_cw;
  return false;
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

// ---- Local map ----------------------------------------------------------------------------------

void Tracker::Impl::update_local_keyframes(Frame& frame) {
  // Votes: how many of the frame's points each keyframe observes, counted on the keyframes (a mark
  // per frame instead of a map), then visited in id order (deterministic).
  const std::uint64_t vote_mark = ++keyframe_vote_mark;
  std::vector<KeyFrame*> voters;
  for (MapPoint*& point : frame.points) {
    if (point == nullptr) continue;
    if (point->bad) {
      point = nullptr;
      continue;
    }
    for (const auto& [keyframe, feature] : point->observations) {
      if (keyframe->tracking_vote_mark != vote_mark) {
        keyframe->tracking_vote_mark = vote_mark;
        keyframe->tracking_votes = 0;
        voters.push_back(keyframe);
      }
      ++keyframe->tracking_votes;
    }
  }
  if (voters.empty()) return;
  std::sort(voters.begin(), voters.end(), ById{});

  local_keyframes.clear();
  const std::uint64_t local_mark = ++keyframe_local_mark;  // membership of local_keyframes
  KeyFrame* most_shared = nullptr;
  int most = 0;
  for (KeyFrame* keyframe : voters) {
    if (keyframe->bad) continue;
    local_keyframes.push_back(keyframe);
    keyframe->tracking_local_mark = local_mark;
    if (keyframe->tracking_votes > most) {
      most = keyframe->tracking_votes;
      most_shared = keyframe;
    }
  }
  // Widen by a neighbour of each: a covisible keyframe, a child and the parent (as ORB-SLAM2).
  // Adds `k` when it is a good keyframe not listed yet; says whether it did.
  const auto add_if_new = [&](KeyFrame* k) {
    if (k == nullptr || k->bad || k->tracking_local_mark == local_mark) return false;
    local_keyframes.push_back(k);
    k->tracking_local_mark = local_mark;
    return true;
  };
  const std::size_t voted = local_keyframes.size();
  for (std::size_t k = 0; k < voted && local_keyframes.size() < kMaxLocalKeyframes; ++k) {
    KeyFrame* keyframe = local_keyframes[k];
    for (KeyFrame* covisible : keyframe->best_covisibles(kCovisiblesPerKeyframe)) {
      if (add_if_new(covisible)) break;
    }
    for (const auto& [child, unused] : keyframe->children) {
      if (add_if_new(child)) break;
    }
    add_if_new(keyframe->parent);
  }
  if (most_shared != nullptr) {
    reference_keyframe = most_shared;
    frame.reference_keyframe = most_shared;
  }
}

int Tracker::Impl::search_local_points(Frame& frame) {
  const std::uint64_t mark = ++frame_points_mark;
  for (MapPoint* point : frame.points) {
    if (point == nullptr) continue;
    ++point->visible;
    point->tracking_frame_mark = mark;
  }
  // The local points: each point of the local keyframes once, in the order first met (a mark per
  // build instead of a hash set), projected as it is met (one pass over tens of thousands of
  // keyframe features; a list first and the projection after touched every point twice).
  // `count` says whether a projected point counts as seen (not on a second pass of the frame).
  const auto project_local_points = [&](bool count) {
    const std::uint64_t local_mark = ++local_points_mark;
    const Eigen::Vector3d center = frame.center();
    projected.clear();
    for (const KeyFrame* keyframe : local_keyframes) {
      for (MapPoint* point : keyframe->points) {
        if (point == nullptr || point->bad || point->tracking_local_mark == local_mark) continue;
        point->tracking_local_mark = local_mark;
        if (point->tracking_frame_mark == mark) continue;  // matched already
        tracking::ProjectedPoint p;
        if (!tracking::project_in_frustum(*point, frame, center, geometry, p)) continue;
        if (count) ++point->visible;
        projected.push_back(p);
      }
    }
    if (!projected.empty()) {
      tracking::build_local_queries(projected, kLocalMapWindow, geometry, queries, query_descriptors);
    }
  };
  project_local_points(true);
  if (projected.empty()) return 0;
  std::vector<ProjectionResult> results;
  const auto match = [&] {
    matcher.set_frame(kernel_keypoints(*frame.features, scales_q16), frame.features->descriptors);
    results = matcher.match(queries, query_descriptors);
  };
  if (!without_map_lock(frame, match)) {  // a loop correction moved the points: project them again
    project_local_points(false);
    if (projected.empty()) return 0;
    match();
  }
  return tracking::accept_local_matches(frame, projected, queries, results);
}

bool Tracker::Impl::track_local_map(Frame& frame, TrackingResult& result) {
  update_local_keyframes(frame);
  search_local_points(frame);
  optimize_pose(frame);
  int inliers = 0;
  for (std::size_t i = 0; i < frame.points.size(); ++i) {
    MapPoint* point = frame.points[i];
    if (point == nullptr) continue;
    // Stereo: outliers are dropped right away (ORB-SLAM2); so is a point that local mapping culled
    // or merged while the pose was solved without the lock.
    if (frame.outlier[i] || point->bad) {
      frame.points[i] = nullptr;
      frame.outlier[i] = false;
      continue;
    }
    ++point->found;
    if (!point->observations.empty()) ++inliers;
  }
  result.matches_local_map = inliers;
  local_map_inliers = inliers;
  if (inliers < settings.min_tracked_inliers) {
    lost_reason = "local map: " + std::to_string(inliers) + " inliers after pose optimisation (need " +
                  "min_tracked_inliers = " + std::to_string(settings.min_tracked_inliers) + ")";
    return false;
  }
  return true;
}

// ---- Keyframes ----------------------------------------------------------------------------------

bool Tracker::Impl::need_new_keyframe(const Frame& frame) const {
  if (reference_keyframe == nullptr) return false;
  const std::size_t keyframes = map.num_keyframes();
  const int min_observations = keyframes <= 2 ? 2 : 3;
  const int reference_matches = reference_keyframe->tracked_points(min_observations);
  const bool mapper_idle = mapper.accepts_keyframes();
  // Busy with nothing queued counts as free (SlamSettings::keyframes_while_mapping).
  const bool mapper_free = mapper_idle || (settings.keyframes_while_mapping && mapper.queued_keyframes() == 0);

  // Close stereo points (reliable depth): tracked ones, and ones a keyframe could turn into points.
  const FrameFeatures& f = *frame.features;
  const double close = settings.close_depth_m();
  int tracked_close = 0, untracked_close = 0;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (!f.has_depth(i) || f.depth_m[i] >= close) continue;
    if (frame.points[i] != nullptr && !frame.outlier[i]) {
      ++tracked_close;
    } else {
      ++untracked_close;
    }
  }
  const bool need_close = tracked_close < 100 && untracked_close > 70;
  const double ratio = keyframes < 2 ? 0.4 : 0.75;

  const bool max_frames_passed =
      frame.id >= last_keyframe_frame_id + static_cast<std::uint64_t>(settings.max_frames_between_keyframes);
  // (0 asks nothing of the ids, which a caller of track() numbers as it likes.)
  const auto min_gap = static_cast<std::uint64_t>(settings.min_frames_between_keyframes);
  const bool idle_and_passed = mapper_free && (min_gap == 0 || frame.id >= last_keyframe_frame_id + min_gap);
  const bool weak = local_map_inliers < 0.25 * reference_matches || need_close;
  const bool fewer_than_reference =
      (local_map_inliers < ratio * reference_matches || need_close) && local_map_inliers > 15;
  if (!((max_frames_passed || idle_and_passed || weak) && fewer_than_reference)) return false;
  // Idle, or busy with nothing queued: the keyframe waits for the step under way, which goes on.
  if (mapper_free) return true;
  mapper.interrupt_bundle_adjustment();
  return mapper.queued_keyframes() < 3;
}

KeyFrame* Tracker::Impl::create_keyframe(Frame& frame) {
  KeyFrame* keyframe = map.add_keyframe(frame);
  // The frame's matches go to the keyframe; local mapping links their observations (and
  // updates their descriptors and normals) when it processes the keyframe.
  for (std::size_t i = 0; i < frame.points.size(); ++i) {
    if (frame.points[i] != nullptr && !frame.points[i]->bad) keyframe->points[i] = frame.points[i];
  }
  // New points from the closest stereo features: all closer than close_depth_m, at least 100.
  const FrameFeatures& f = *frame.features;
  std::vector<std::pair<float, int>> by_depth;
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (f.has_depth(i)) by_depth.emplace_back(f.depth_m[i], static_cast<int>(i));
  }
  std::sort(by_depth.begin(), by_depth.end());
  const double close = settings.close_depth_m();
  int points = 0;
  for (const auto& [depth, feature] : by_depth) {
    const auto i = static_cast<std::size_t>(feature);
    MapPoint* existing = frame.points[i];
    if (existing == nullptr || existing->observations.empty()) {
      MapPoint* point = map.add_point(frame.unproject_stereo(i, settings.camera), keyframe, frame.id);
      Map::add_observation(point, keyframe, feature);
      point->update_descriptor();
      point->update_normal_and_depth(pyramid);
      frame.points[i] = point;
      frame.outlier[i] = false;
    }
    ++points;
    if (depth > close && points > 100) break;
  }
  frame.reference_keyframe = keyframe;
  reference_keyframe = keyframe;
  last_keyframe_frame_id = frame.id;
  mapper.insert_keyframe(keyframe);
  return keyframe;
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
  std::unique_lock<std::mutex> lock = t.map.lock_first();  // local mapping's fusion yields to it
  result.map_wait_ns = elapsed_ns(wait_start);
  const auto start = std::chrono::steady_clock::now();
  // Impl::without_map_lock may release `lock` and take it back, and counts the time in `result`.
  struct LockScope {
    Impl& t;
    LockScope(Impl& impl, TrackingResult& result, std::unique_lock<std::mutex>& lock) : t(impl) {
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
  last_frame_ = std::move(frame);
  return result;
}

}  // namespace porta::slam
