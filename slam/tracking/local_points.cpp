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
  const std::uint64_t mark = ++mark_;
  next_.clear();
  next_starts_.resize(keyframes.size());
  kept_ = 0;
  scanned_ = 0;
  // While every keyframe so far is the one listed before in its place and gave the points it gave
  // then, the set met so far is the one of before; an unedited keyframe then gives its points of
  // before again (the ones gone bad since included: the caller skips them).
  bool as_before = true;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    KeyFrame* keyframe = keyframes[k];
    next_starts_[k] = next_.size();
    const bool listed_here = as_before && k < keyframes_.size() && keyframes_[k] == keyframe;
    const std::size_t begin = listed_here ? starts_[k] : 0;
    const std::size_t end = listed_here ? (k + 1 < starts_.size() ? starts_[k + 1] : points_.size()) : 0;
    if (listed_here && keyframe->points_edits == edits_[k]) {
      for (std::size_t i = begin; i < end; ++i) {
        MapPoint* point = points_[i];
        point->tracking_local_mark = mark;
        next_.push_back(point);
      }
      kept_ += end - begin;
      continue;
    }
    scanned_ += keyframe->points.size();
    for (MapPoint* point : keyframe->points) {
      if (point == nullptr || point->bad || point->tracking_local_mark == mark) continue;
      point->tracking_local_mark = mark;
      next_.push_back(point);
    }
    // An edited keyframe whose good points met first are those of before (an edit elsewhere in
    // it, a slot of a culled point cleared) leaves the set met so far as it was.
    if (listed_here) {
      std::size_t i = next_starts_[k];
      for (std::size_t j = begin; j < end && as_before; ++j) {
        if (points_[j]->bad) continue;
        as_before = i < next_.size() && next_[i] == points_[j];
        ++i;
      }
      as_before = as_before && i == next_.size();
    } else {
      as_before = false;
    }
  }
  points_.swap(next_);
  starts_.swap(next_starts_);
  keyframes_.assign(keyframes.begin(), keyframes.end());
  edits_.resize(keyframes.size());
  for (std::size_t k = 0; k < keyframes.size(); ++k) edits_[k] = keyframes[k]->points_edits;
}

}  // namespace porta::slam::tracking
