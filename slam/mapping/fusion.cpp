// Local mapping step 4: duplicate fusion with the neighbours (after ORB-SLAM2's SearchInNeighbors
// and ORBmatcher::Fuse); see mapping_steps.hpp. The caller holds Map::mutex throughout: the work
// is a projection and a small window search per point.
#include <set>

#include "mapping_steps.hpp"
#include "porta/slam/optim/chi2.hpp"

namespace porta::slam::mapping {

int fuse_points_into(KeyFrame* keyframe, const std::vector<MapPoint*>& points, const StereoCamera& camera,
                     const ScalePyramid& pyramid, double radius_factor, int* added) {
  const FrameFeatures& features = *keyframe->features;
  const SE3 T_cw = keyframe->T_cw;
  const Eigen::Vector3d center = keyframe->center();
  const double bf = camera.bf();
  int merged = 0;
  std::vector<int> candidates;
  for (MapPoint* point : points) {
    if (point == nullptr || point->bad || point->observations.count(keyframe) != 0) continue;
    const Eigen::Vector3d p_c = T_cw * point->position;
    if (!(p_c.z() > 0.0)) continue;
    const double inv_z = 1.0 / p_c.z();
    const double u = camera.fx * p_c.x() * inv_z + camera.cx;
    const double v = camera.fy * p_c.y() * inv_z + camera.cy;
    if (u < 0.0 || u >= camera.width || v < 0.0 || v >= camera.height) continue;
    const double u_right = u - bf * inv_z;

    // Within the scale-invariance range, seen from less than 60 degrees off its mean direction.
    const Eigen::Vector3d ray = point->position - center;
    const double distance = ray.norm();
    if (distance < 0.8 * point->min_distance || distance > 1.2 * point->max_distance) continue;
    if (ray.dot(point->normal) < 0.5 * distance) continue;

    const int predicted_level = point->predict_level(distance, pyramid);
    const double radius = radius_factor * pyramid.scale[static_cast<std::size_t>(predicted_level)];
    keyframe->grid.in_area(features, static_cast<float>(u), static_cast<float>(v), static_cast<float>(radius),
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
      const int d = descriptor_distance(point->descriptor, features.descriptors[s]);
      if (d < best_distance) {  // ties keep the smaller feature index
        best_distance = d;
        best_feature = i;
      }
    }
    if (best_feature < 0 || best_distance > kHammingLow) continue;

    MapPoint* existing = keyframe->points[static_cast<std::size_t>(best_feature)];
    if (existing != nullptr && !existing->bad) {
      // Keep the better-established point (more observations); ties keep the projected one.
      if (existing->num_observations() > point->num_observations()) {
        Map::replace(point, existing);
      } else {
        Map::replace(existing, point);
      }
      ++merged;
    } else {
      Map::add_observation(point, keyframe, best_feature);
      if (added != nullptr) ++*added;
    }
  }
  return merged;
}

int fuse_with_neighbours(Map& map, std::unique_lock<std::mutex>& lock, KeyFrame* keyframe,
                         const SlamSettings& settings, const ScalePyramid& pyramid) {
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
    merged += fuse_points_into(target, own, settings.camera, pyramid);
  }
  if (map.yield_to_waiters(lock) && keyframe->bad) return merged;
  // The targets' points into the keyframe, each point once, in the order first met (membership by
  // a pass mark: tens of thousands of slots, under the lock tracking waits for).
  std::vector<MapPoint*> candidates;
  const std::uint64_t mark = new_pass_mark();
  for (KeyFrame* target : targets) {
    for (MapPoint* point : target->points) {
      if (point == nullptr || point->bad || point->collect_mark == mark) continue;
      point->collect_mark = mark;
      candidates.push_back(point);
    }
  }
  merged += fuse_points_into(keyframe, candidates, settings.camera, pyramid);

  for (MapPoint* point : keyframe->points) {
    if (point == nullptr || point->bad) continue;
    point->update_descriptor();
    point->update_normal_and_depth(pyramid);
  }
  keyframe->update_connections();
  return merged;
}

}  // namespace porta::slam::mapping
