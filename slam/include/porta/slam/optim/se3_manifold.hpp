// The pose parameterisation shared by every optimisation in porta_optim (docs/ARCHITECTURE.md,
// "SLAM optimisation"):
//   - an optimised pose is T_cw (world -> camera), as ORB-SLAM2's g2o vertices;
//   - it is stored as 7 doubles [qx qy qz qw tx ty tz]: the rotation quaternion in Eigen's coeffs()
//     order (x y z w, Hamilton, unit norm) followed by the translation;
//   - its tangent is 6 doubles [phi; rho] (rotation first, as g2o's SE3Quat) and an increment is
//     applied on the LEFT:  T <- exp(delta) * T  with the exact SE(3) exponential.
// Se3Manifold implements this for Ceres, with Plus/Minus and their Jacobians mutually consistent;
// the cost functions in reprojection_costs.hpp return true derivatives with respect to the 7
// ambient parameters, which Ceres multiplies by PlusJacobian to get tangent Jacobians.
#pragma once

#include <ceres/manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

#include "porta/slam/pose.hpp"

namespace porta::slam::optim {

inline constexpr int kPoseAmbientSize = 7;
inline constexpr int kPoseTangentSize = 6;

using PoseParams = std::array<double, kPoseAmbientSize>;

/// T_cw -> [qx qy qz qw tx ty tz] (unit quaternion with qw >= 0).
PoseParams pose_to_params(const SE3& T_cw);
/// [qx qy qz qw tx ty tz] -> T_cw (the quaternion is normalised first).
SE3 params_to_pose(const double* params);

/// SO(3) exponential (rotation vector -> unit quaternion) and logarithm (-> rotation vector with
/// angle in [0, pi]); both stable near the identity.
Eigen::Quaterniond so3_exp(const Eigen::Vector3d& phi);
Eigen::Vector3d so3_log(const Eigen::Quaterniond& q);

/// SE(3) exponential of [phi; rho]: rotation Exp(phi), translation V(phi) * rho.
SE3 se3_exp(const Eigen::Matrix<double, 6, 1>& delta);
/// Inverse of se3_exp for rotation angles below pi.
Eigen::Matrix<double, 6, 1> se3_log(const SE3& T);

/// SE(3) on 7 ambient parameters with a left increment: Plus(x, d) = exp(d) * x,
/// Minus(y, x) = log(y * x^-1). PlusJacobian is d Plus(x, d)/d d at d = 0 (7x6), MinusJacobian is
/// d Minus(y, x)/d y at y = x (6x7); MinusJacobian * PlusJacobian = I6 on unit quaternions.
class Se3Manifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseAmbientSize; }
  int TangentSize() const override { return kPoseTangentSize; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

}  // namespace porta::slam::optim
