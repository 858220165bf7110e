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

/// The point in the camera frame, p = R(q) X + t, for 7 pose parameters (no normalisation of q,
/// as in the residuals).
Eigen::Vector3d transform_to_camera(const double* pose_params, const Eigen::Vector3d& point_world);

}  // namespace porta::slam::optim
