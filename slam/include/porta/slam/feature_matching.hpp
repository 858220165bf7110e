// Keyframe-to-keyframe descriptor matching pieces shared by local mapping (triangulation) and loop
// closing (after ORB-SLAM2's ORBmatcher): a match list and the rotation-consistency filter.
#pragma once

#include <vector>

#include "porta/slam/frame.hpp"

namespace porta::slam {

/// Feature `feature1` of one frame matched to `feature2` of another at Hamming `distance`.
struct FeatureMatch {
  int feature1 = -1;
  int feature2 = -1;
  int distance = 0;
};

/// Brute-force descriptor matching of features `from_a` of `a` against features `from_b` of `b`
/// (ORB-SLAM2's SearchByBoW without the vocabulary's pre-grouping): the best `b` feature of each
/// `a` feature must be within `max_distance` and below `ratio` x the second best; each `b` feature
/// keeps only its closest partner (ties: the smaller `a` feature); then orientation consistency.
/// Matches come in ascending `a` feature order.
std::vector<FeatureMatch> match_by_descriptor(const FrameFeatures& a, const std::vector<int>& from_a,
                                              const FrameFeatures& b, const std::vector<int>& from_b,
                                              int max_distance, double ratio);

/// Keeps the matches whose orientation change (angle in f1 minus angle in f2) falls in the three
/// most populated of 30 histogram bins (the second and third only when they hold at least a tenth
/// of the first; ties to the smaller bin), as ORB-SLAM2. Order of the kept matches is unchanged.
void keep_consistent_rotations(std::vector<FeatureMatch>& matches, const FrameFeatures& f1,
                               const FrameFeatures& f2);

}  // namespace porta::slam
