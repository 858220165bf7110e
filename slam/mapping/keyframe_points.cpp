// Local mapping steps 1 and 2: linking a new keyframe's points and culling recent points
// (ORB-SLAM2's ProcessNewKeyFrame and MapPointCulling); see mapping_steps.hpp.
#include "mapping_steps.hpp"

namespace porta::slam::mapping {

std::vector<MapPoint*> link_keyframe_points(Map& map, std::unique_lock<std::mutex>& lock, KeyFrame* keyframe,
                                            const ScalePyramid& pyramid) {
  // A keyframe links ~1 000 points (a descriptor and a normal each): ~1 ms under the lock on a
  // desktop core, which a tracker running at hundreds of frames per second would wait for whole.
  constexpr std::size_t kLinkChunk = 128;
  std::vector<MapPoint*> created;
  for (std::size_t i = 0; i < keyframe->points.size(); ++i) {
    // After a yield every point is read again (loop closing may have fused some meanwhile).
    if (i > 0 && i % kLinkChunk == 0 && map.yield_to_waiters(lock) && keyframe->bad) return created;
    MapPoint* point = keyframe->points[i];
    if (point == nullptr) continue;
    // Tracking may hand over a point that fusion merged while the keyframe waited in the queue.
    while (point->bad && point->replaced_by != nullptr) point = point->replaced_by;
    if (point->bad) {
      keyframe->points[i] = nullptr;
      continue;
    }
    // Tracking sets the keyframe's matched points with or without Map::add_observation (its new
    // stereo points always with it); a missing observation is added here so both sides agree.
    const auto it = point->observations.find(keyframe);
    if (it == point->observations.end()) {
      Map::add_observation(point, keyframe, static_cast<int>(i));
    } else if (it->second != static_cast<int>(i)) {
      keyframe->points[i] = nullptr;  // the point is already seen by another feature of this keyframe
      continue;
    }
    if (point->reference == nullptr) point->reference = keyframe;
    point->update_normal_and_depth(pyramid);
    point->update_descriptor();
    if (point->first_keyframe_id == keyframe->id) created.push_back(point);
  }
  keyframe->update_connections();
  return created;
}

int cull_recent_points(std::vector<MapPoint*>& recent, std::uint64_t current_keyframe_id) {
  int culled = 0;
  std::vector<MapPoint*> kept;
  kept.reserve(recent.size());
  for (MapPoint* point : recent) {
    if (point->bad) continue;
    const std::uint64_t age =
        current_keyframe_id >= point->first_keyframe_id ? current_keyframe_id - point->first_keyframe_id : 0;
    if (point->found_ratio() < 0.25 ||
        (age >= 2 && point->num_observations() <= kMaxRecentObservationsToCull)) {
      Map::set_bad(point);
      ++culled;
    } else if (age < 3) {
      kept.push_back(point);
    }
  }
  recent = std::move(kept);
  return culled;
}

}  // namespace porta::slam::mapping
