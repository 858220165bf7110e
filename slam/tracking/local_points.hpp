// Tracking's local points (ORB-SLAM2's UpdateLocalPoints): the distinct good map points of the
// local keyframes, in the order first met. Internal to slam/tracking; under Map::mutex.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "porta/slam/map.hpp"

namespace porta::slam::tracking {

/// The local keyframes hold ~10 entries for each distinct point (~41 000 for ~4 100 on KITTI), and
/// consecutive frames share most keyframes. So the list is kept from one update to the next for
/// the leading keyframes that are the same, in the same places, with no edit to their points since
/// (KeyFrame::points_edits); only the keyframes after them are scanned again. The list is a scan
/// of every keyframe's, but for points turned bad since (the caller skips them): an edited
/// keyframe, and every keyframe after it, is scanned again, and a point culled or replaced leaves
/// (set_point) every keyframe among its observations. Only a keyframe that tracking made and
/// local mapping has not linked yet may hold a point without being among its observations.
class LocalPoints {
 public:
  /// Lists the points of `keyframes` (good keyframes, each once).
  void update(const std::vector<KeyFrame*>& keyframes);
  /// Forgets the list: the next update scans every keyframe.
  void clear();

  const std::vector<MapPoint*>& points() const { return points_; }
  /// Leading points the last update kept from the one before, and keyframe entries it scanned.
  std::size_t kept() const { return kept_; }
  std::size_t scanned() const { return scanned_; }

 private:
  std::vector<KeyFrame*> keyframes_;   // of the last update
  std::vector<std::uint64_t> edits_;   // their points_edits then
  std::vector<std::size_t> starts_;    // where each one's first-met points begin in points_
  std::vector<MapPoint*> points_;
  std::uint64_t mark_ = 0;             // MapPoint::tracking_local_mark of the last update
  std::size_t kept_ = 0, scanned_ = 0;
};

}  // namespace porta::slam::tracking
