// Tracking's local points kept across frames; see local_points.hpp.
#include "local_points.hpp"

namespace porta::slam::tracking {

void LocalPoints::clear() {
  keyframes_.clear();
  edits_.clear();
  starts_.clear();
  points_.clear();
}

void LocalPoints::update(const std::vector<KeyFrame*>& keyframes) {
  std::size_t same = 0;
  while (same < keyframes.size() && same < keyframes_.size() && keyframes[same] == keyframes_[same] &&
         keyframes[same]->points_edits == edits_[same]) {
    ++same;
  }
  // The points first met in the unchanged keyframes stay; they are marked so the scan of the rest
  // skips them.
  if (same < keyframes_.size()) points_.resize(starts_[same]);
  kept_ = points_.size();
  const std::uint64_t mark = ++mark_;
  for (MapPoint* point : points_) point->tracking_local_mark = mark;

  keyframes_.assign(keyframes.begin(), keyframes.end());
  edits_.resize(keyframes.size());
  starts_.resize(keyframes.size());
  scanned_ = 0;
  for (std::size_t k = same; k < keyframes.size(); ++k) {
    KeyFrame* keyframe = keyframes[k];
    edits_[k] = keyframe->points_edits;
    starts_[k] = points_.size();
    scanned_ += keyframe->points.size();
    for (MapPoint* point : keyframe->points) {
      if (point == nullptr || point->bad || point->tracking_local_mark == mark) continue;
      point->tracking_local_mark = mark;
      points_.push_back(point);
    }
  }
}

}  // namespace porta::slam::tracking
