// Rigid (6-dof, no scale) alignment of 3-D point sets and its RANSAC between two stereo keyframes,
// used by loop closing to verify a loop candidate (after ORB-SLAM2's Sim3Solver with the scale
// fixed to 1, as for a stereo map). Single-threaded and deterministic: the same input and seed give
// bit-identical output (ransac_random.hpp).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "porta/slam/pose.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::optim {

/// Least-squares rigid transform T minimising sum |to_i - T * from_i|^2 (Horn / Umeyama: SVD of the
/// cross-covariance, with the sign fix that keeps det R = +1 where the best orthogonal fit is a
/// reflection). std::nullopt when the sizes differ, there are fewer than 3 pairs, the points are
/// coincident or collinear (the cross-covariance's second singular value is negligible against the
/// first: the rotation about the line is then undetermined), or a value is not finite.
/// Coplanar points (3 or more, not collinear) are fine.
std::optional<SE3> align_rigid(std::span<const Eigen::Vector3d> from, std::span<const Eigen::Vector3d> to);

/// One 3-D point seen by two stereo keyframes A and B (e.g. a map point of A matched to one of B).
struct RigidCorrespondence {
  Eigen::Vector3d point_a = Eigen::Vector3d::Zero();  ///< the point in camera A's frame (metres)
  Eigen::Vector3d point_b = Eigen::Vector3d::Zero();  ///< the same physical point in camera B's frame
  Eigen::Vector2d uv_a = Eigen::Vector2d::Zero();     ///< where A observes it (pixels, left image)
  Eigen::Vector2d uv_b = Eigen::Vector2d::Zero();     ///< where B observes it (pixels, left image)
  double sigma2_a = 1.0, sigma2_b = 1.0;              ///< pixel variances of the two keypoints
};

struct RigidRansacOptions {
  double probability = 0.99;  ///< of drawing one all-inlier sample; in (0, 1)
  int min_inliers = 20;       ///< found needs this many inliers; >= 3
  int max_iterations = 300;   ///< cap on the adaptive iteration count; >= 1
  double chi2 = 9.210;        ///< per-view squared pixel error bound, in units of sigma2 (chi2 2 DoF, 99%)
  std::uint64_t seed = 1;
};

struct RigidRansacResult {
  bool found = false;          ///< num_inliers >= min_inliers
  SE3 T_ab = SE3::Identity();  ///< maps B-frame points into A: point_a ~ T_ab * point_b
  std::vector<bool> inlier;    ///< per correspondence, for T_ab (all false when nothing was found)
  int num_inliers = 0;
  int iterations = 0;  ///< RANSAC hypotheses drawn (0 when there were too few correspondences)
};

/// RANSAC over minimal samples of 3 correspondences, each aligned with align_rigid (degenerate
/// samples count as iterations). A correspondence is an inlier of T_ab when both reprojections pass
/// with positive depth: |uv_a - project(T_ab * point_b)|^2 < chi2 * sigma2_a and
/// |uv_b - project(T_ab^-1 * point_a)|^2 < chi2 * sigma2_b (left camera of `camera`). The hypothesis
/// with the most inliers wins (ties: the first found); the iteration count adapts to its inlier ratio
/// (ransac_required_iterations) up to max_iterations. The winner is refined by align_rigid on all its
/// inliers and re-classified; the refined pose is kept when it has at least as many inliers.
/// With fewer correspondences than max(3, min_inliers) it returns at once, found = false.
/// Throws std::invalid_argument naming the field for an invalid camera, invalid options, or a
/// correspondence with sigma2 <= 0.
RigidRansacResult ransac_rigid(const StereoCamera& camera,
                               std::span<const RigidCorrespondence> correspondences,
                               const RigidRansacOptions& options = {});

}  // namespace porta::slam::optim
