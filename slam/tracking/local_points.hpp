// Tracking's local points (ORB-SLAM2's UpdateLocalPoints): the distinct good map points of the
// local keyframes, in the order first met. Internal to slam/tracking; under Map::mutex.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "porta/slam/map.hpp"

namespace porta::slam::tracking {

/// The local keyframes hold ~10 entries for each distinct point (~54 000 for ~6 600 on KITTI), and
/// consecutive frames share most keyframes. So each keyframe's share of the list (the points it
/// met first) is kept from one update to the next while every keyframe before it is the one of
/// before in its place and gave its share of before: then an unedited keyframe (KeyFrame::
/// points_edits) gives its share again without a scan. An edited keyframe is scanned; when its
/// share comes out as before (an edit among points met earlier, or a culled point's slot cleared),
/// the keyframes after it may still keep theirs. The list is a scan of every keyframe's, but for
/// points turned bad since (the caller skips them): a point culled or replaced leaves (set_point)
/// every keyframe among its observations; only a keyframe that tracking made and local mapping has
/// not linked yet may hold a point without being among them.
class LocalPoints {
 public:
  /// Lists the points of `keyframes` (good keyframes, each once).
  void update(const std::vector<KeyFrame*>& keyframes);
  /// Forgets the list: the next update scans every keyframe.
  void clear();

  const std::vector<MapPoint*>& points() const { return points_; }
  /// Points the last update kept from the one before without a scan, and keyframe entries it scanned.
  std::size_t kept() const { return kept_; }
  std::size_t scanned() const { return scanned_; }

 private:
  std::vector<KeyFrame*> keyframes_;   // of the last update
  std::vector<std::uint64_t> edits_;   // their points_edits then
  std::vector<std::size_t> starts_;    // where each one's first-met points begin in points_
  std::vector<MapPoint*> points_;
  std::vector<MapPoint*> next_;          // the list being made (swapped with points_)
  std::vector<std::size_t> next_starts_;
  std::uint64_t mark_ = 0;             // MapPoint::tracking_local_mark of the last update
  std::size_t kept_ = 0, scanned_ = 0;
};

}  // namespace porta::slam::tracking
