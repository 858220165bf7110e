// Tracking's local map (its keyframes, the search of their points, the pose against them) and the
// keyframe decision and creation, after ORB-SLAM2's stereo Tracking; see tracker.hpp.
#include <algorithm>
#include <utility>

#include "tracker_impl.hpp"

namespace porta::slam {


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
  // The local points (each point of the local keyframes once, in the order first met; mostly kept
  // from the frame before, tracking::LocalPoints) projected into the frame. `count` says whether a
  // projected point counts as seen (not on a second pass of the frame).
  const auto project_local_points = [&](bool count) {
    local_points.update(local_keyframes);
    const Eigen::Vector3d center = frame.center();
    projected.clear();
    for (MapPoint* point : local_points.points()) {
      // bad: culled or replaced since it was listed, while only a keyframe not yet linked held it
      // (its point is not among the point's observations, so the cull did not edit it).
      if (point->bad || point->tracking_frame_mark == mark) continue;  // or matched already
      tracking::ProjectedPoint p;
      if (!tracking::project_in_frustum(*point, frame, center, geometry, p)) continue;
      if (count) ++point->visible;
      projected.push_back(p);
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
  if (!without_map_lock(frame, match)) {  // the map moved meanwhile: project the points again
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
    if (frame.points[i] != nullptr && !frame.points[i]->bad) keyframe->set_point(i, frame.points[i]);
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
}  // namespace porta::slam
