// Local mapping steps 1 and 2: linking a new keyframe's points and culling recent points
// (ORB-SLAM2's ProcessNewKeyFrame and MapPointCulling); see mapping_steps.hpp.
#include <algorithm>

#include "mapping_steps.hpp"

namespace porta::slam::mapping {

std::vector<MapPoint*> link_keyframe_points(Map& map, std::unique_lock<MapMutex>& lock, KeyFrame* keyframe,
                                            const ScalePyramid& pyramid, cpu::ThreadPool* pool) {
  // A keyframe links ~1 000 points (a descriptor and a normal each): ~1 ms under the lock on a
  // desktop core, which a tracker running at hundreds of frames per second would wait for whole, so
  // every kLinkChunk points it may take the lock. With a pool the chunk's points are linked in order
  // and then refreshed in parallel: a point's refresh reads its own observations and writes its own
  // fields, so the values are those of the one-thread order; the work per chunk is then a fraction,
  // and a handover to tracking (which keeps the lock for its whole frame) would cost mapping more
  // than the chunk itself, so the chunks are larger.
  constexpr std::size_t kLinkChunk = 128;
  constexpr std::size_t kPooledLinkChunk = 1024;
  const bool pooled = pool != nullptr && pool->size() > 1;
  const std::size_t chunk = pooled ? kPooledLinkChunk : kLinkChunk;
  std::vector<MapPoint*> created, linked;
  const auto refresh = [&pyramid](MapPoint* point) {
    point->update_normal_and_depth(pyramid);
    point->update_descriptor();
  };
  for (std::size_t begin = 0; begin < keyframe->points.size(); begin += chunk) {
    // After a yield every point is read again (loop closing may have fused some meanwhile).
    if (begin > 0 && map.yield_to_waiters(lock) && keyframe->bad) return created;
    const std::size_t end = std::min(begin + chunk, keyframe->points.size());
    linked.clear();
    for (std::size_t i = begin; i < end; ++i) {
      MapPoint* point = keyframe->points[i];
      if (point == nullptr) continue;
      // Tracking may hand over a point that fusion merged while the keyframe waited in the queue.
      while (point->bad && point->replaced_by != nullptr) point = point->replaced_by;
      if (point->bad) {
        keyframe->set_point(i, nullptr);
        continue;
      }
      // Tracking sets the keyframe's matched points with or without Map::add_observation (its new
      // stereo points always with it); a missing observation is added here so both sides agree.
      const auto it = point->observations.find(keyframe);
      if (it == point->observations.end()) {
        Map::add_observation(point, keyframe, static_cast<int>(i));
      } else if (it->second != static_cast<int>(i)) {
        keyframe->set_point(i, nullptr);  // the point is already seen by another feature of this keyframe
        continue;
      }
      if (point->reference == nullptr) point->reference = keyframe;
      linked.push_back(point);
      if (point->first_keyframe_id == keyframe->id) created.push_back(point);
    }
    if (pooled) {
      pool->parallel_for(0, static_cast<std::int64_t>(linked.size()),
                         [&](std::int64_t k) { refresh(linked[static_cast<std::size_t>(k)]); });
    } else {
      for (MapPoint* point : linked) refresh(point);
    }
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
