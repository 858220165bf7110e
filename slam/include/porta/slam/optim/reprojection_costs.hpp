// Reprojection residuals of ORB-SLAM2's bundle adjustment edges, with analytic Jacobians, for Ceres.
//
// A world point X is seen by a camera with pose T_cw (7 parameters, see se3_manifold.hpp) at
// p = R(q) X + t. Predictions: u = fx p.x/p.z + cx, v = fy p.y/p.z + cy, and for stereo
// u_r = u - bf/p.z. Residual = sqrt_information * (observation - prediction), so that its squared
// norm is ORB-SLAM2's chi2 = e^T (I / sigma^2) e with sigma = scale_factor^level (level_sigma2()).
//
// Jacobians are the true derivatives with respect to the ambient parameters: 7 for the pose
// (R(q) is Eigen's polynomial quaternion-to-matrix map, differentiated as such) and 3 for the point;
// Ceres turns the pose Jacobian into a tangent Jacobian through Se3Manifold::PlusJacobian.
// Evaluate fails (returns false) only when the point lies in the camera's z = 0 plane.
#pragma once

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <cmath>

#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::optim {

/// What the residuals need of the camera: pinhole intrinsics and bf (pixels * metres).
struct ProjectionModel {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0, bf = 0.0;
  static ProjectionModel from(const StereoCamera& camera) {
    return {camera.fx, camera.fy, camera.cx, camera.cy, camera.bf()};
  }
};

/// A keypoint measurement: left image (u_left, v) and, for stereo, the right column u_right.
struct StereoMeasurement {
  double u_left = 0.0, v = 0.0, u_right = 0.0;
};

/// Residual s * (observation - prediction) of a point p already in the camera frame, for 2 rows
/// (u, v) or 3 (u, v, u_r), and, when dr_dp is given, its derivative d residual / d p. False when p
/// lies in the z = 0 plane. The cost functions below and the Schur solver of the bundle adjustment
/// (schur_solver.hpp) share it, so that both minimise the same residuals.
template <int kRows>
inline bool camera_residual(const ProjectionModel& m, const double* observation, double s, const Eigen::Vector3d& p,
                            double* residuals, Eigen::Matrix<double, kRows, 3>* dr_dp) {
  static_assert(kRows == 2 || kRows == 3);
  if (!(std::abs(p.z()) > 1e-12)) return false;
  const double inv_z = 1.0 / p.z();
  const double u = m.fx * p.x() * inv_z + m.cx;
  residuals[0] = s * (observation[0] - u);
  residuals[1] = s * (observation[1] - (m.fy * p.y() * inv_z + m.cy));
  if constexpr (kRows == 3) residuals[2] = s * (observation[2] - (u - m.bf * inv_z));
  if (dr_dp == nullptr) return true;
  const double inv_z2 = inv_z * inv_z;
  dr_dp->row(0) << -s * m.fx * inv_z, 0.0, s * m.fx * p.x() * inv_z2;
  dr_dp->row(1) << 0.0, -s * m.fy * inv_z, s * m.fy * p.y() * inv_z2;
  if constexpr (kRows == 3) dr_dp->row(2) << -s * m.fx * inv_z, 0.0, -s * (m.bf - m.fx * p.x()) * inv_z2;
  return true;
}

/// 3 residuals (u_l, v, u_r); parameters: pose T_cw (7), world point (3).
class StereoReprojectionCost final : public ceres::SizedCostFunction<3, 7, 3> {
 public:
  StereoReprojectionCost(const ProjectionModel& model, const StereoMeasurement& measurement,
                         double sqrt_information);
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override;

 private:
  ProjectionModel model_;
  StereoMeasurement measurement_;
  double sqrt_information_;
};

/// 2 residuals (u, v); parameters: pose T_cw (7), world point (3).
class MonoReprojectionCost final : public ceres::SizedCostFunction<2, 7, 3> {
 public:
  MonoReprojectionCost(const ProjectionModel& model, double u, double v, double sqrt_information);
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override;

 private:
  ProjectionModel model_;
  double u_, v_;
  double sqrt_information_;
};

/// StereoReprojectionCost with the world point held fixed: parameter pose T_cw (7) only.
class StereoPoseOnlyCost final : public ceres::SizedCostFunction<3, 7> {
 public:
  StereoPoseOnlyCost(const ProjectionModel& model, const StereoMeasurement& measurement,
                     double sqrt_information, const Eigen::Vector3d& point_world);
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override;

 private:
  ProjectionModel model_;
  StereoMeasurement measurement_;
  double sqrt_information_;
  Eigen::Vector3d point_world_;
};

/// MonoReprojectionCost with the world point held fixed: parameter pose T_cw (7) only.
class MonoPoseOnlyCost final : public ceres::SizedCostFunction<2, 7> {
 public:
  MonoPoseOnlyCost(const ProjectionModel& model, double u, double v, double sqrt_information,
                   const Eigen::Vector3d& point_world);
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override;

 private:
  ProjectionModel model_;
  double u_, v_;
  double sqrt_information_;
  Eigen::Vector3d point_world_;
};

/// R(q) of 7 pose parameters, the rotation the residuals use (Eigen's polynomial map, no
/// normalisation of q).
Eigen::Matrix3d pose_rotation(const double* pose_params);

/// The point in the camera frame, p = R(q) X + t, for 7 pose parameters (no normalisation of q,
/// as in the residuals).
Eigen::Vector3d transform_to_camera(const double* pose_params, const Eigen::Vector3d& point_world);

}  // namespace porta::slam::optim
