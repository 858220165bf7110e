// Analytic reprojection residuals and Jacobians; see reprojection_costs.hpp for the model.
#include "porta/slam/optim/reprojection_costs.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace porta::slam::optim {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// R(q) = (1 - 2|v|^2) I + 2 v v^T + 2 w [v]x: Eigen's toRotationMatrix() written as one polynomial,
// equal to the rotation for unit q and differentiated below as it stands.
Mat3 rotation_of(const double* q) {
  const Vec3 v(q[0], q[1], q[2]);
  return (1.0 - 2.0 * v.squaredNorm()) * Mat3::Identity() + 2.0 * v * v.transpose() + 2.0 * q[3] * skew(v);
}

// d(R(q) X)/dq, columns (qx qy qz qw). With R X = X + 2w v x X + 2 v x (v x X) and
// v x (v x X) = v (v.X) - X |v|^2:  d/dv = -2w [X]x + 2 ((v.X) I + v X^T - 2 X v^T),  d/dw = 2 v x X.
Eigen::Matrix<double, 3, 4> rotate_jacobian_q(const double* q, const Vec3& X) {
  const Vec3 v(q[0], q[1], q[2]);
  Eigen::Matrix<double, 3, 4> J;
  J.leftCols<3>() = -2.0 * q[3] * skew(X) +
                    2.0 * (v.dot(X) * Mat3::Identity() + v * X.transpose() - 2.0 * X * v.transpose());
  J.col(3) = 2.0 * v.cross(X);
  return J;
}

// Residual s * (observation - prediction) for 2 (u, v) or 3 (u, v, u_r) rows, with optional
// row-major Jacobians for the pose (kRows x 7) and the point (kRows x 3).
template <int kRows>
bool evaluate_reprojection(const ProjectionModel& m, const double (&observation)[kRows], double s,
                           const double* pose, const Vec3& X, double* residuals, double* jacobian_pose,
                           double* jacobian_point) {
  const Mat3 R = rotation_of(pose);
  const Vec3 p = R * X + Vec3(pose[4], pose[5], pose[6]);
  if (jacobian_pose == nullptr && jacobian_point == nullptr) {
    return camera_residual<kRows>(m, observation, s, p, residuals, nullptr);
  }
  Eigen::Matrix<double, kRows, 3> dr_dp;
  if (!camera_residual<kRows>(m, observation, s, p, residuals, &dr_dp)) return false;

  if (jacobian_pose != nullptr) {
    Eigen::Map<Eigen::Matrix<double, kRows, 7, Eigen::RowMajor>> J(jacobian_pose);
    J.template leftCols<4>() = dr_dp * rotate_jacobian_q(pose, X);
    J.template rightCols<3>() = dr_dp;
  }
  if (jacobian_point != nullptr) {
    Eigen::Map<Eigen::Matrix<double, kRows, 3, Eigen::RowMajor>> J(jacobian_point);
    J = dr_dp * R;
  }
  return true;
}

double* jacobian_or_null(double** jacobians, int i) { return jacobians == nullptr ? nullptr : jacobians[i]; }

}  // namespace

Mat3 pose_rotation(const double* pose_params) { return rotation_of(pose_params); }

Vec3 transform_to_camera(const double* pose_params, const Vec3& point_world) {
  return rotation_of(pose_params) * point_world + Vec3(pose_params[4], pose_params[5], pose_params[6]);
}

StereoReprojectionCost::StereoReprojectionCost(const ProjectionModel& model,
                                               const StereoMeasurement& measurement, double sqrt_information)
    : model_(model), measurement_(measurement), sqrt_information_(sqrt_information) {}

bool StereoReprojectionCost::Evaluate(const double* const* parameters, double* residuals,
                                      double** jacobians) const {
  const double observation[3] = {measurement_.u_left, measurement_.v, measurement_.u_right};
  return evaluate_reprojection<3>(model_, observation, sqrt_information_, parameters[0],
                                  Vec3(parameters[1][0], parameters[1][1], parameters[1][2]), residuals,
                                  jacobian_or_null(jacobians, 0), jacobian_or_null(jacobians, 1));
}

MonoReprojectionCost::MonoReprojectionCost(const ProjectionModel& model, double u, double v,
                                           double sqrt_information)
    : model_(model), u_(u), v_(v), sqrt_information_(sqrt_information) {}

bool MonoReprojectionCost::Evaluate(const double* const* parameters, double* residuals,
                                    double** jacobians) const {
  const double observation[2] = {u_, v_};
  return evaluate_reprojection<2>(model_, observation, sqrt_information_, parameters[0],
                                  Vec3(parameters[1][0], parameters[1][1], parameters[1][2]), residuals,
                                  jacobian_or_null(jacobians, 0), jacobian_or_null(jacobians, 1));
}

StereoPoseOnlyCost::StereoPoseOnlyCost(const ProjectionModel& model, const StereoMeasurement& measurement,
                                       double sqrt_information, const Vec3& point_world)
    : model_(model),
      measurement_(measurement),
      sqrt_information_(sqrt_information),
      point_world_(point_world) {}

bool StereoPoseOnlyCost::Evaluate(const double* const* parameters, double* residuals,
                                  double** jacobians) const {
  const double observation[3] = {measurement_.u_left, measurement_.v, measurement_.u_right};
  return evaluate_reprojection<3>(model_, observation, sqrt_information_, parameters[0], point_world_,
                                  residuals, jacobian_or_null(jacobians, 0), nullptr);
}

MonoPoseOnlyCost::MonoPoseOnlyCost(const ProjectionModel& model, double u, double v, double sqrt_information,
                                   const Vec3& point_world)
    : model_(model), u_(u), v_(v), sqrt_information_(sqrt_information), point_world_(point_world) {}

bool MonoPoseOnlyCost::Evaluate(const double* const* parameters, double* residuals,
                                double** jacobians) const {
  const double observation[2] = {u_, v_};
  return evaluate_reprojection<2>(model_, observation, sqrt_information_, parameters[0], point_world_,
                                  residuals, jacobian_or_null(jacobians, 0), nullptr);
}

}  // namespace porta::slam::optim
