// SE(3) with a left increment on [qx qy qz qw tx ty tz]; see se3_manifold.hpp for the conventions.
#include "porta/slam/optim/se3_manifold.hpp"

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

// Below this angle the closed forms of V and V^-1 lose digits to cancellation; their Taylor series
// (truncated after the theta^4 term) are then exact to double precision.
constexpr double kSmallAngle = 1e-2;

// V(phi) = I + a K + b K^2 (K = [phi]x): the left Jacobian of SO(3), maps rho to the translation.
Mat3 left_jacobian(const Vec3& phi) {
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  double a = 0.0;
  double b = 0.0;
  if (theta < kSmallAngle) {
    a = 0.5 - theta2 / 24.0 + theta2 * theta2 / 720.0;
    b = 1.0 / 6.0 - theta2 / 120.0 + theta2 * theta2 / 5040.0;
  } else {
    const double half_sin = std::sin(0.5 * theta);
    a = 2.0 * half_sin * half_sin / theta2;  // (1 - cos) / theta^2 without cancellation
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  const Mat3 K = skew(phi);
  return Mat3::Identity() + a * K + b * K * K;
}

// V(phi)^-1 = I - K/2 + c K^2, c = (1 - (theta/2) cot(theta/2)) / theta^2, valid for theta < 2 pi.
Mat3 left_jacobian_inverse(const Vec3& phi) {
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  double c = 0.0;
  if (theta < kSmallAngle) {
    c = 1.0 / 12.0 + theta2 / 720.0 + theta2 * theta2 / 30240.0;
  } else {
    const double half = 0.5 * theta;
    c = (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
  }
  const Mat3 K = skew(phi);
  return Mat3::Identity() - 0.5 * K + c * K * K;
}

Eigen::Quaterniond unit_quaternion(const double* params) {
  return Eigen::Quaterniond(params[3], params[0], params[1], params[2]).normalized();
}

void write_params(const Eigen::Quaterniond& q, const Vec3& t, double* params) {
  params[0] = q.x();
  params[1] = q.y();
  params[2] = q.z();
  params[3] = q.w();
  params[4] = t.x();
  params[5] = t.y();
  params[6] = t.z();
}

}  // namespace

PoseParams pose_to_params(const SE3& T_cw) {
  Eigen::Quaterniond q(T_cw.linear());
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  PoseParams p{};
  write_params(q, T_cw.translation(), p.data());
  return p;
}

SE3 params_to_pose(const double* params) {
  SE3 T = SE3::Identity();
  T.linear() = unit_quaternion(params).toRotationMatrix();
  T.translation() = Vec3(params[4], params[5], params[6]);
  return T;
}

Eigen::Quaterniond so3_exp(const Vec3& phi) {
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  double sin_half_over_theta = 0.0;
  double cos_half = 0.0;
  if (theta < 1e-8) {
    sin_half_over_theta = 0.5 - theta2 / 48.0;
    cos_half = 1.0 - theta2 / 8.0;
  } else {
    sin_half_over_theta = std::sin(0.5 * theta) / theta;
    cos_half = std::cos(0.5 * theta);
  }
  const Vec3 v = sin_half_over_theta * phi;
  return Eigen::Quaterniond(cos_half, v.x(), v.y(), v.z());
}

Vec3 so3_log(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // the shorter way round: angle in [0, pi]
  const Vec3 v = q.vec();
  const double n = v.norm();
  const double w = q.w();
  // theta = 2 atan2(n, w); phi = theta / n * v. Near the identity theta / n -> 2 / w (1 - n^2 / 3w^2).
  const double factor = n < 1e-8 ? 2.0 / w * (1.0 - n * n / (3.0 * w * w)) : 2.0 * std::atan2(n, w) / n;
  return factor * v;
}

SE3 se3_exp(const Eigen::Matrix<double, 6, 1>& delta) {
  const Vec3 phi = delta.head<3>();
  SE3 T = SE3::Identity();
  T.linear() = so3_exp(phi).toRotationMatrix();
  T.translation() = left_jacobian(phi) * delta.tail<3>();
  return T;
}

Eigen::Matrix<double, 6, 1> se3_log(const SE3& T) {
  const Vec3 phi = so3_log(Eigen::Quaterniond(T.linear()));
  Eigen::Matrix<double, 6, 1> delta;
  delta << phi, left_jacobian_inverse(phi) * T.translation();
  return delta;
}

bool Se3Manifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Vec3 phi(delta[0], delta[1], delta[2]);
  const Vec3 rho(delta[3], delta[4], delta[5]);
  const Eigen::Quaterniond dq = so3_exp(phi);
  const Eigen::Quaterniond q = (dq * unit_quaternion(x)).normalized();
  const Vec3 t = dq * Vec3(x[4], x[5], x[6]) + left_jacobian(phi) * rho;
  write_params(q, t, x_plus_delta);
  return true;
}

bool Se3Manifold::PlusJacobian(const double* x, double* jacobian) const {
  // q' = Exp(phi) (x) q ~ (phi/2, 1) (x) q:  dq'/dphi = 1/2 [w I - [v]x ; -v^T]  (rows x y z w)
  // t' = Exp(phi) t + V(phi) rho:            dt'/dphi = -[t]x,  dt'/drho = I
  const Eigen::Quaterniond q = unit_quaternion(x);
  const Vec3 v = q.vec();
  const Vec3 t(x[4], x[5], x[6]);
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.block<3, 3>(0, 0) = 0.5 * (q.w() * Mat3::Identity() - skew(v));
  J.block<1, 3>(3, 0) = -0.5 * v.transpose();
  J.block<3, 3>(4, 0) = -skew(t);
  J.block<3, 3>(4, 3) = Mat3::Identity();
  return true;
}

bool Se3Manifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Eigen::Quaterniond qx = unit_quaternion(x);
  const Eigen::Quaterniond dq = unit_quaternion(y) * qx.conjugate();
  const Vec3 phi = so3_log(dq);
  const Vec3 dt = Vec3(y[4], y[5], y[6]) - dq * Vec3(x[4], x[5], x[6]);
  const Vec3 rho = left_jacobian_inverse(phi) * dt;
  for (int i = 0; i < 3; ++i) {
    y_minus_x[i] = phi[i];
    y_minus_x[3 + i] = rho[i];
  }
  return true;
}

bool Se3Manifold::MinusJacobian(const double* x, double* jacobian) const {
  // At y = x: phi ~ 2 vec(q_y (x) q_x^*), so dphi/dq_y = 2 [w I + [v]x | -v] (which also kills the
  // radial direction, as Minus normalises q_y); rho ~ t_y - t_x + [t_x]x phi.
  const Eigen::Quaterniond q = unit_quaternion(x);
  const Vec3 v = q.vec();
  const Vec3 t(x[4], x[5], x[6]);
  Eigen::Matrix<double, 3, 4> dphi_dq;
  dphi_dq.leftCols<3>() = 2.0 * (q.w() * Mat3::Identity() + skew(v));
  dphi_dq.col(3) = -2.0 * v;
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.block<3, 4>(0, 0) = dphi_dq;
  J.block<3, 4>(3, 0) = skew(t) * dphi_dq;
  J.block<3, 3>(3, 4) = Mat3::Identity();
  return true;
}

}  // namespace porta::slam::optim
