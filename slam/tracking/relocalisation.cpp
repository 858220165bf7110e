// Relocalisation against candidate keyframes; see relocalisation.hpp.
#include "relocalisation.hpp"

#include <algorithm>

#include "porta/slam/feature_matching.hpp"
#include "porta/slam/optim/pnp.hpp"

namespace porta::slam::tracking {
namespace {

// ORB-SLAM2's numbers.
constexpr int kMinDescriptorMatches = 15;
constexpr double kMatchRatio = 0.75;
constexpr int kMinPnpInliers = 10;
constexpr int kMinInliers = 50;
constexpr int kMinInliersToRetry = 30;  // between this and kMinInliers: a narrower second search
constexpr double kWideWindowPx = 10.0, kNarrowWindowPx = 3.0;

int count_matches(const Frame& frame) {
  return static_cast<int>(std::count_if(frame.points.begin(), frame.points.end(), [](const MapPoint* p) { return p != nullptr; }));
}

/// One candidate; returns the inliers (0 when it failed) and says why in `reason`.
int try_keyframe(Frame& frame, KeyFrame& keyframe, const SearchGeometry& geometry, double stereo_depth_limit_m,
                 std::string& reason) {
  const FrameFeatures& f = *frame.features;
  std::vector<int> all_frame(f.size()), with_point;
  for (std::size_t i = 0; i < f.size(); ++i) all_frame[i] = static_cast<int>(i);
  for (std::size_t j = 0; j < keyframe.points.size(); ++j) {
    if (keyframe.points[j] != nullptr && !keyframe.points[j]->bad) with_point.push_back(static_cast<int>(j));
  }
  const std::vector<FeatureMatch> matches =
      match_by_descriptor(f, all_frame, *keyframe.features, with_point, kMaxDistanceLow, kMatchRatio);
  const std::string what = "keyframe " + std::to_string(keyframe.id) + ": ";
  if (static_cast<int>(matches.size()) < kMinDescriptorMatches) {
    reason = what + std::to_string(matches.size()) + " descriptor matches (need " +
             std::to_string(kMinDescriptorMatches) + ")";
    return 0;
  }
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> uv;
  std::vector<double> sigma2;
  for (const FeatureMatch& m : matches) {
    const auto i = static_cast<std::size_t>(m.feature1);
    points.push_back(keyframe.points[static_cast<std::size_t>(m.feature2)]->position);
    uv.push_back(f.uv[i].cast<double>());
    sigma2.push_back(geometry.pyramid.sigma2[f.level[i]]);
  }
  optim::PnpRansacOptions options;
  options.min_inliers = kMinPnpInliers;
  options.seed = 0x7e10c000u + frame.id * 131 + keyframe.id;  // reproducible, different per try
  const optim::PnpRansacResult pnp = optim::solve_pnp_ransac(geometry.camera, points, uv, sigma2, options);
  if (!pnp.found) {
    reason = what + "EPnP RANSAC found " + std::to_string(pnp.num_inliers) + " inliers of " +
             std::to_string(matches.size()) + " matches (need " + std::to_string(kMinPnpInliers) + ")";
    return 0;
  }
  std::fill(frame.points.begin(), frame.points.end(), nullptr);
  for (std::size_t m = 0; m < matches.size(); ++m) {
    if (pnp.inlier[m]) {
      frame.points[static_cast<std::size_t>(matches[m].feature1)] =
          keyframe.points[static_cast<std::size_t>(matches[m].feature2)];
    }
  }
  frame.T_cw = pnp.T_cw;
  int good = optimize_frame_pose(frame, geometry, stereo_depth_limit_m);
  discard_outliers(frame);
  if (good < kMinPnpInliers) {
    reason = what + std::to_string(good) + " inliers after pose optimisation";
    return 0;
  }
  // More matches by projecting the keyframe's points with the pose found.
  if (good < kMinInliers && good + search_keyframe(frame, keyframe, kWideWindowPx, geometry) >= kMinInliers) {
    good = optimize_frame_pose(frame, geometry, stereo_depth_limit_m);
    if (good > kMinInliersToRetry && good < kMinInliers) {
      discard_outliers(frame);
      if (good + search_keyframe(frame, keyframe, kNarrowWindowPx, geometry) >= kMinInliers) {
        good = optimize_frame_pose(frame, geometry, stereo_depth_limit_m);
      }
    }
    discard_outliers(frame);
  }
  if (good < kMinInliers) {
    reason = what + std::to_string(good) + " inliers (" + std::to_string(count_matches(frame)) +
             " matches) after the guided search (need " + std::to_string(kMinInliers) + ")";
    return 0;
  }
  return good;
}

}  // namespace

Relocalisation relocalise(Frame& frame, const std::vector<KeyFrame*>& candidates, const SearchGeometry& geometry,
                          double stereo_depth_limit_m) {
  Relocalisation result;
  if (candidates.empty()) {
    result.reason = "the place-recognition database knows no keyframe like this frame (" +
                    std::to_string(frame.features->size()) + " features)";
    return result;
  }
  const SE3 initial = frame.T_cw;
  for (KeyFrame* keyframe : candidates) {
    if (keyframe->bad) continue;
    std::string reason;
    const int inliers = try_keyframe(frame, *keyframe, geometry, stereo_depth_limit_m, reason);
    if (inliers > 0) {
      result.ok = true;
      result.keyframe = keyframe;
      result.inliers = inliers;
      return result;
    }
    if (result.reason.empty()) result.reason = reason;  // the best-scored candidate's story
  }
  result.reason = std::to_string(candidates.size()) + " candidate keyframes, none verified (best: " + result.reason + ")";
  std::fill(frame.points.begin(), frame.points.end(), nullptr);
  frame.T_cw = initial;
  return result;
}

}  // namespace porta::slam::tracking
