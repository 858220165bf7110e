// Local mapping step 4: duplicate fusion with the neighbours (after ORB-SLAM2's SearchInNeighbors
// and ORBmatcher::Fuse); see mapping_steps.hpp. The caller holds Map::mutex throughout: the work
// is a projection and a small window search per point.
//
// With a pool, every point's search runs first, in parallel, from the map as it is when the pass
// starts; the points are then applied in order as before, each taking its search's result unless
// a merge earlier in the same pass changed what the search reads. The search reads the point's
// position, normal, distance range and descriptor and the keyframe's features: of these a pass
// changes only the descriptor of a merge's survivor (Map::replace), whose search is then made
// again (with the lists fusion passes, each point listed once, a survivor is the point just applied
// or one the keyframe already sees, so this is a guard for other callers). Whether a point is bad or
// already seen by the keyframe is checked when it is applied. So every point meets the feature the
// one-thread pass would give it, and the map is the same.
#include <set>
#include <unordered_set>

#include "mapping_steps.hpp"
#include "porta/slam/optim/chi2.hpp"

namespace porta::slam::mapping {
namespace {

/// Fewer points than this are searched in the pass itself (a parallel_for costs more than it saves).
constexpr std::size_t kParallelFusionPoints = 64;
/// A point's search result that was not made ahead.
constexpr int kNotSearched = -2;

bool takes_part(const MapPoint* point, KeyFrame* keyframe) {
  return point != nullptr && !point->bad && point->observations.count(keyframe) == 0;
}

/// ORBmatcher::Fuse's search of one point in `keyframe`: the feature of least Hamming distance
/// (within kHammingLow) in the window around its projection, or -1. `candidates` is scratch.
int fusion_search(const KeyFrame& keyframe, const MapPoint& point, const StereoCamera& camera,
                  const ScalePyramid& pyramid, double radius_factor, std::vector<int>& candidates) {
  const FrameFeatures& features = *keyframe.features;
  const Eigen::Vector3d p_c = keyframe.T_cw * point.position;
  if (!(p_c.z() > 0.0)) return -1;
  const double inv_z = 1.0 / p_c.z();
  const double u = camera.fx * p_c.x() * inv_z + camera.cx;
  const double v = camera.fy * p_c.y() * inv_z + camera.cy;
  if (u < 0.0 || u >= camera.width || v < 0.0 || v >= camera.height) return -1;
  const double u_right = u - camera.bf() * inv_z;

  // Within the scale-invariance range, seen from less than 60 degrees off its mean direction.
  const Eigen::Vector3d ray = point.position - keyframe.center();
  const double distance = ray.norm();
  if (distance < 0.8 * point.min_distance || distance > 1.2 * point.max_distance) return -1;
  if (ray.dot(point.normal) < 0.5 * distance) return -1;

  const int predicted_level = point.predict_level(distance, pyramid);
  const double radius = radius_factor * pyramid.scale[static_cast<std::size_t>(predicted_level)];
  keyframe.grid.in_area(features, static_cast<float>(u), static_cast<float>(v), static_cast<float>(radius),
                        std::max(0, predicted_level - 1), predicted_level, candidates);
  int best_distance = 256, best_feature = -1;
  for (const int i : candidates) {
    const auto s = static_cast<std::size_t>(i);
    const double du = u - features.uv[s].x(), dv = v - features.uv[s].y();
    const double inv_sigma2 = pyramid.inv_sigma2[features.level[s]];
    if (features.has_depth(s)) {
      const double dr = u_right - features.u_right[s];
      if ((du * du + dv * dv + dr * dr) * inv_sigma2 > optim::kChi2Stereo95) continue;
    } else if ((du * du + dv * dv) * inv_sigma2 > optim::kChi2Mono95) {
      continue;
    }
    const int d = descriptor_distance(point.descriptor, features.descriptors[s]);
    if (d < best_distance) {  // ties keep the smaller feature index
      best_distance = d;
      best_feature = i;
    }
  }
  return best_distance <= kHammingLow ? best_feature : -1;
}

}  // namespace

int fuse_points_into(KeyFrame* keyframe, const std::vector<MapPoint*>& points, const StereoCamera& camera,
                     const ScalePyramid& pyramid, double radius_factor, int* added, cpu::ThreadPool* pool) {
  std::vector<int> ahead;  // per point: its search made from the map at the start, or kNotSearched
  if (pool != nullptr && pool->size() > 1 && points.size() >= kParallelFusionPoints) {
    ahead.assign(points.size(), kNotSearched);
    pool->parallel_for(0, static_cast<std::int64_t>(points.size()), [&](std::int64_t k) {
      thread_local std::vector<int> scratch;
      const MapPoint* point = points[static_cast<std::size_t>(k)];
      if (!takes_part(point, keyframe)) return;
      ahead[static_cast<std::size_t>(k)] = fusion_search(*keyframe, *point, camera, pyramid, radius_factor, scratch);
    });
  }
  std::unordered_set<const MapPoint*> descriptor_changed;  // survivors of this pass's merges
  std::vector<int> candidates;
  int merged = 0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    MapPoint* point = points[k];
    if (!takes_part(point, keyframe)) continue;
    const bool searched = !ahead.empty() && ahead[k] != kNotSearched && descriptor_changed.count(point) == 0;
    const int best_feature =
        searched ? ahead[k] : fusion_search(*keyframe, *point, camera, pyramid, radius_factor, candidates);
    if (best_feature < 0) continue;

    MapPoint* existing = keyframe->points[static_cast<std::size_t>(best_feature)];
    if (existing != nullptr && !existing->bad) {
      // Keep the better-established point (more observations); ties keep the projected one.
      if (existing->num_observations() > point->num_observations()) {
        Map::replace(point, existing);
        descriptor_changed.insert(existing);
      } else {
        Map::replace(existing, point);
        descriptor_changed.insert(point);
      }
      ++merged;
    } else {
      Map::add_observation(point, keyframe, best_feature);
      if (added != nullptr) ++*added;
    }
  }
  return merged;
}

int fuse_with_neighbours(Map& map, std::unique_lock<MapMutex>& lock, KeyFrame* keyframe,
                         const SlamSettings& settings, const ScalePyramid& pyramid, cpu::ThreadPool* pool) {
  if (keyframe->bad) return 0;
  // Targets: the best covisible keyframes and, for each, its own best five (second order).
  std::vector<KeyFrame*> targets;
  std::set<std::uint64_t> target_ids{keyframe->id};
  for (KeyFrame* first : keyframe->best_covisibles(kNeighbours)) {
    if (first->bad || !target_ids.insert(first->id).second) continue;
    targets.push_back(first);
  }
  const std::size_t first_order = targets.size();
  for (std::size_t t = 0; t < first_order; ++t) {
    for (KeyFrame* second : targets[t]->best_covisibles(5)) {
      if (second->bad || !target_ids.insert(second->id).second) continue;
      targets.push_back(second);
    }
  }

  int merged = 0;
  // The keyframe's points into every target. Between targets a waiting tracker may take the map;
  // after that, a keyframe that turned bad meanwhile is skipped (the points are checked as used).
  for (KeyFrame* target : targets) {
    if (map.yield_to_waiters(lock) && keyframe->bad) return merged;
    if (target->bad) continue;
    const std::vector<MapPoint*> own = keyframe->points;  // copy: fusion rewrites the keyframe's slots
    merged += fuse_points_into(target, own, settings.camera, pyramid, 3.0, nullptr, pool);
  }
  if (map.yield_to_waiters(lock) && keyframe->bad) return merged;
  // The targets' points into the keyframe, each point once, in the order first met (membership by
  // a pass mark: tens of thousands of slots, under the lock tracking waits for).
  std::vector<MapPoint*> candidates;
  std::uint64_t mark = new_pass_mark();
  for (KeyFrame* target : targets) {
    for (MapPoint* point : target->points) {
      if (point == nullptr || point->bad || point->collect_mark == mark) continue;
      point->collect_mark = mark;
      candidates.push_back(point);
    }
  }
  merged += fuse_points_into(keyframe, candidates, settings.camera, pyramid, 3.0, nullptr, pool);

  // Each of the keyframe's points refreshed once; a point's refresh writes only its own fields.
  std::vector<MapPoint*> refreshed;
  mark = new_pass_mark();
  for (MapPoint* point : keyframe->points) {
    if (point == nullptr || point->bad || point->collect_mark == mark) continue;
    point->collect_mark = mark;
    refreshed.push_back(point);
  }
  const auto refresh = [&](std::int64_t k) {
    MapPoint* point = refreshed[static_cast<std::size_t>(k)];
    point->update_descriptor();
    point->update_normal_and_depth(pyramid);
  };
  if (pool != nullptr && pool->size() > 1) {
    pool->parallel_for(0, static_cast<std::int64_t>(refreshed.size()), refresh);
  } else {
    for (std::size_t k = 0; k < refreshed.size(); ++k) refresh(static_cast<std::int64_t>(k));
  }
  keyframe->update_connections();
  return merged;
}

}  // namespace porta::slam::mapping
