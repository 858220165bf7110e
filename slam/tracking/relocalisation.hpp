// Relocalisation (after ORB-SLAM2's Tracking::Relocalization, written from its description): the
// frame's descriptors matched against each candidate keyframe's map points, EPnP in RANSAC, pose
// optimisation, then more matches by projection until 50 inliers. Internal to slam/tracking; runs
// under Map::mutex.
#pragma once

#include <string>
#include <vector>

#include "frame_search.hpp"

namespace porta::slam::tracking {

struct Relocalisation {
  bool ok = false;
  KeyFrame* keyframe = nullptr;  ///< the candidate it succeeded with
  int inliers = 0;
  std::string reason;  ///< why it failed, naming the best attempt
};

/// Tries the candidates in order; on success frame.T_cw and frame.points hold the pose and the
/// inlier matches (outliers dropped). `stereo_depth_limit_m` goes to every pose optimisation
/// (optimize_frame_pose).
Relocalisation relocalise(Frame& frame, const std::vector<KeyFrame*>& candidates, const SearchGeometry& geometry,
                          double stereo_depth_limit_m = std::numeric_limits<double>::infinity());

}  // namespace porta::slam::tracking
