// Camera pose from 3-D world points and their pixels (Perspective-n-Point), used by relocalisation:
// EPnP (Lepetit, Moreno-Noguer, Fua, IJCV 2009) and its RANSAC (after ORB-SLAM2's PnPsolver).
// Poses are T_cw (world -> camera); a camera sees X at p = R X + t and pixel
// (fx px/pz + cx, fy py/pz + cy), left camera of the StereoCamera. Single-threaded and
// deterministic: the same input and seed give bit-identical output (ransac_random.hpp).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "porta/slam/pose.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::optim {

/// EPnP from n >= 4 correspondences: the world points are written in barycentric coordinates of 4
/// control points (centroid + principal axes; 3 when the points are coplanar); the control points'
/// camera coordinates lie in the null space of the 2n x 12 (2n x 9) projection system M, as a
/// combination of N = 1, 2, 3 or 4 eigenvectors of M^T M whose weights come from the preserved
/// inter-control-point distances (linearised; relinearised for N = 4; then Gauss-Newton). Each
/// candidate's pose is a rigid alignment (align_rigid) of the world points onto the camera-frame
/// points, and the candidate with the smallest reprojection error is returned (no further pose-space
/// refinement). Exact on noise-free data (to rounding) from 5 points; from 4 points in all but rare
/// near-degenerate configurations. std::nullopt when the sizes differ, n < 4, the world points are
/// coincident or collinear, or no candidate gives a finite pose.
std::optional<SE3> solve_epnp(std::span<const Eigen::Vector3d> points_world,
                              std::span<const Eigen::Vector2d> uv, const StereoCamera& camera);

struct PnpRansacOptions {
  double probability = 0.99;  ///< of drawing one all-inlier sample; in (0, 1)
  int min_inliers = 10;       ///< found needs this many inliers; >= 4
  int max_iterations = 300;   ///< cap on the adaptive iteration count; >= 1
  int min_set = 4;            ///< points per EPnP hypothesis; >= 4
  double chi2 = 5.991;        ///< squared pixel error bound in units of sigma2 (chi2 2 DoF, 95%)
  std::uint64_t seed = 1;
};

struct PnpRansacResult {
  bool found = false;          ///< num_inliers >= min_inliers
  SE3 T_cw = SE3::Identity();  ///< world -> camera
  std::vector<bool> inlier;    ///< per correspondence, for T_cw (all false when nothing was found)
  int num_inliers = 0;
  int iterations = 0;  ///< RANSAC hypotheses drawn (0 when there were too few correspondences)
};

/// RANSAC over samples of min_set correspondences, each solved by solve_epnp (failed samples count
/// as iterations). Correspondence i is an inlier of T_cw when (T_cw X_i).z > 0 and
/// |uv_i - project(T_cw X_i)|^2 < chi2 * sigma2_i. The hypothesis with the most inliers wins (ties:
/// the first found); the iteration count adapts to its inlier ratio (ransac_required_iterations) up
/// to max_iterations. The winner is refined by solve_epnp on all its inliers and re-classified; the
/// refined pose is kept when it has at least as many inliers. With fewer correspondences than
/// max(min_set, min_inliers) it returns at once, found = false.
/// Throws std::invalid_argument naming the field for an invalid camera, invalid options, spans of
/// different sizes, or a sigma2 <= 0.
PnpRansacResult solve_pnp_ransac(const StereoCamera& camera, std::span<const Eigen::Vector3d> points_world,
                                 std::span<const Eigen::Vector2d> uv, std::span<const double> sigma2,
                                 const PnpRansacOptions& options = {});

}  // namespace porta::slam::optim
