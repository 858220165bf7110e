// Tracking's matching steps (after ORB-SLAM2's ORBmatcher, written from its description): map
// points projected into the current frame and matched by descriptor in a window, and the pose-only
// optimisation over the frame's matches. Internal to slam/tracking; all of it runs under Map::mutex,
// except optim::optimize_pose on a FramePoseProblem (a copy) and the projection matcher's kernel.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "porta/slam/frame.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/optim/pose_optimization.hpp"
#include "porta/slam/projection_matcher.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::tracking {

inline constexpr int kMaxDistanceHigh = 100;  ///< ORB-SLAM2's TH_HIGH
inline constexpr int kMaxDistanceLow = 50;    ///< ORB-SLAM2's TH_LOW (its bag-of-words search)
inline constexpr int kRotationBins = 30;      ///< orientation-consistency histogram

/// What matching needs to know about the camera and the pyramid.
struct SearchGeometry {
  const StereoCamera& camera;
  const ScalePyramid& pyramid;
  const std::vector<std::int32_t>& scales_q16;
};

/// Motion model: the last frame's map points (not outliers) projected with current.T_cw, searched
/// within th * scale(level) px, levels constrained by the forward/backward motion (stereo), best
/// distance <= TH_HIGH, stereo right-column check, rotation consistency. Fills current.points;
/// returns the number of matches.
int search_last_frame(Frame& current, const Frame& last, double th_px, const SearchGeometry& geometry);

/// Fallback without a vocabulary: the keyframe's map points projected with current.T_cw (the last
/// pose), a wide window of th * scale(predicted level) px, levels predicted +-1, best distance <=
/// TH_LOW, ratio 0.7 to the second best, rotation consistency. Returns the number of matches.
int search_keyframe(Frame& current, const KeyFrame& keyframe, double th_px, const SearchGeometry& geometry);

/// A local-map point that passed the frustum check, with where it should appear.
struct ProjectedPoint {
  MapPoint* point = nullptr;
  double u = 0.0, v = 0.0, u_right = 0.0;  ///< level-0 px; u_right: right image column
  int level = 0;                           ///< predicted pyramid level
  double view_cos = 0.0;                   ///< cosine between the viewing ray and the point's normal
};

/// ORB-SLAM2's frustum check: in front, inside the image, distance within [0.8 min, 1.2 max] of the
/// point's scale-invariance range, viewing angle within 60 degrees of its normal.
/// `center` is the frame's camera centre in the world.
bool project_in_frustum(MapPoint& point, const Frame& frame, const Eigen::Vector3d& center,
                        const SearchGeometry& geometry, ProjectedPoint& out);

/// The queries of the local-map search for `points` (window th * 2.5 or 4.0 * scale(level) px, as
/// ORB-SLAM2's radius by viewing angle; levels [level - 1, level]).
void build_local_queries(const std::vector<ProjectedPoint>& points, double th, const SearchGeometry& geometry,
                         std::vector<ProjectionQuery>& queries, std::vector<Descriptor>& descriptors);

/// Applies the host-side checks to the projection-match results in query order: best distance <=
/// TH_HIGH, best < 0.8 * second, feature not matched yet, stereo right-column within the window.
/// Fills frame.points; returns the number of new matches.
/// A point that local mapping culled or merged since it was projected (tracking released the map's
/// lock for the kernel) is not accepted.
int accept_local_matches(Frame& frame, const std::vector<ProjectedPoint>& points,
                         const std::vector<ProjectionQuery>& queries,
                         const std::vector<ProjectionResult>& results);

/// The pose-only optimisation's input, copied from the map: one observation per matched feature.
struct FramePoseProblem {
  std::vector<optim::PoseObservation> observations;
  std::vector<std::size_t> feature_of;  ///< the frame's feature of each observation
};

/// Copies the frame's matches into a pose problem (needs Map::mutex) and clears frame.outlier.
/// Features whose stereo depth exceeds `stereo_depth_limit_m` count by their left-image position
/// only (monocular observations).
FramePoseProblem frame_pose_problem(Frame& frame, const SearchGeometry& geometry,
                                    double stereo_depth_limit_m);

/// Applies optim::optimize_pose's result on `problem`: sets frame.T_cw and frame.outlier; returns
/// the inliers (0, pose unchanged, when it did not optimise).
int apply_frame_pose(Frame& frame, const FramePoseProblem& problem,
                     const optim::PoseOptimizationResult& result);

/// Pose-only optimisation over every matched feature of the frame (optim/pose_optimization.hpp),
/// all three steps above under the lock: sets frame.T_cw and frame.outlier; returns the inliers.
int optimize_frame_pose(Frame& frame, const SearchGeometry& geometry,
                        double stereo_depth_limit_m = std::numeric_limits<double>::infinity());

/// Drops the matches flagged as outliers (frame.points[i] = nullptr); returns the matches left
/// whose point has observations.
int discard_outliers(Frame& frame);

}  // namespace porta::slam::tracking
