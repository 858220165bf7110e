// Map point creation (after ORB-SLAM2's LocalMapping::CreateNewMapPoints and Frame::UnprojectStereo):
// linear two-view triangulation and the checks a new point must pass, each a separate helper so
// that the caller can order them (the cheap parallax test first) and report why a point failed.
// Poses are T_cw (world -> camera); "normalized" coordinates are ((u - cx) / fx, (v - cy) / fy).
#pragma once

#include <Eigen/Core>
#include <optional>

#include "porta/slam/optim/chi2.hpp"
#include "porta/slam/pose.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::optim {

/// ORB-SLAM2 triangulates only rays whose parallax cosine is below this (angle > ~1.15 degrees).
inline constexpr double kMaxParallaxCosine = 0.9998;

/// Pixel -> normalized image coordinates (z = 1 ray in the camera frame).
Eigen::Vector2d normalize_pixel(const StereoCamera& camera, double u, double v);

/// Linear (DLT) triangulation of normalized observations x1, x2 seen from T_c1w, T_c2w: the right
/// singular vector of the 4x4 system x * P.row(2) - P.row(0|1) = 0 with the smallest singular
/// value, dehomogenised. std::nullopt when the solution lies at infinity (or is not finite).
std::optional<Eigen::Vector3d> triangulate_linear(const SE3& T_c1w, const Eigen::Vector2d& x1_normalized,
                                                  const SE3& T_c2w, const Eigen::Vector2d& x2_normalized);

/// Same, from pixel observations (u, v) of the left camera.
std::optional<Eigen::Vector3d> triangulate_linear_pixels(const StereoCamera& camera, const SE3& T_c1w,
                                                         const Eigen::Vector2d& pixel1, const SE3& T_c2w,
                                                         const Eigen::Vector2d& pixel2);

/// Cosine of the angle between the two viewing rays (in the world frame) of normalized observations.
double ray_parallax_cosine(const SE3& T_c1w, const Eigen::Vector2d& x1_normalized, const SE3& T_c2w,
                           const Eigen::Vector2d& x2_normalized);

/// Depth (camera z) of a world point, and whether it is strictly positive.
double depth_in_camera(const SE3& T_cw, const Eigen::Vector3d& point_world);
bool has_positive_depth(const SE3& T_cw, const Eigen::Vector3d& point_world);

/// Mono reprojection test: squared pixel error of (u, v) <= chi2_threshold * sigma2 (and z > 0).
bool reprojection_within(const StereoCamera& camera, const SE3& T_cw, const Eigen::Vector3d& point_world,
                         double u, double v, double sigma2, double chi2_threshold = kChi2Mono95);
/// Stereo reprojection test on (u_left, v, u_right) with the 3-DoF threshold.
bool stereo_reprojection_within(const StereoCamera& camera, const SE3& T_cw,
                                const Eigen::Vector3d& point_world, double u_left, double v, double u_right,
                                double sigma2, double chi2_threshold = kChi2Stereo95);

/// One view of a two-view triangulation: pose, pixel (u, v) and the keypoint's level variance.
struct TriangulationView {
  SE3 T_cw = SE3::Identity();
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double sigma2 = 1.0;
};

/// Triangulate and apply ORB-SLAM2's checks in its order: parallax cosine in (0, max_parallax_cosine),
/// linear triangulation, positive depth in both views, mono reprojection chi2 in both views.
/// std::nullopt when any check fails.
std::optional<Eigen::Vector3d> triangulate_checked(const StereoCamera& camera, const TriangulationView& view1,
                                                   const TriangulationView& view2,
                                                   double max_parallax_cosine = kMaxParallaxCosine);

/// Stereo back-projection of a left keypoint (u_left, v) matched at u_right: depth z = bf / (u_left -
/// u_right), x = (u_left - cx) z / fx, y = (v - cy) z / fy, in the camera frame. std::nullopt when
/// the disparity is not positive.
std::optional<Eigen::Vector3d> stereo_backproject_camera(const StereoCamera& camera, double u_left, double v,
                                                         double u_right);
/// The same point in the world: T_cw^-1 * p_c.
std::optional<Eigen::Vector3d> stereo_backproject_world(const StereoCamera& camera, const SE3& T_cw,
                                                        double u_left, double v, double u_right);

}  // namespace porta::slam::optim
