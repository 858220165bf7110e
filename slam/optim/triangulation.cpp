// Two-view triangulation, its acceptance checks and stereo back-projection; see triangulation.hpp.
#include "porta/slam/optim/triangulation.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace porta::slam::optim {

Eigen::Vector2d normalize_pixel(const StereoCamera& camera, double u, double v) {
  return {(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy};
}

std::optional<Eigen::Vector3d> triangulate_linear(const SE3& T_c1w, const Eigen::Vector2d& x1,
                                                  const SE3& T_c2w, const Eigen::Vector2d& x2) {
  const Eigen::Matrix<double, 3, 4> P1 = T_c1w.matrix().topRows<3>();
  const Eigen::Matrix<double, 3, 4> P2 = T_c2w.matrix().topRows<3>();
  Eigen::Matrix4d A;
  A.row(0) = x1.x() * P1.row(2) - P1.row(0);
  A.row(1) = x1.y() * P1.row(2) - P1.row(1);
  A.row(2) = x2.x() * P2.row(2) - P2.row(0);
  A.row(3) = x2.y() * P2.row(2) - P2.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  // |w| relative to the whole vector: tiny means the rays are (numerically) parallel.
  if (!(std::abs(X.w()) > 1e-12 * X.norm())) return std::nullopt;
  const Eigen::Vector3d point = X.head<3>() / X.w();
  if (!point.allFinite()) return std::nullopt;
  return point;
}

std::optional<Eigen::Vector3d> triangulate_linear_pixels(const StereoCamera& camera, const SE3& T_c1w,
                                                         const Eigen::Vector2d& pixel1, const SE3& T_c2w,
                                                         const Eigen::Vector2d& pixel2) {
  return triangulate_linear(T_c1w, normalize_pixel(camera, pixel1.x(), pixel1.y()), T_c2w,
                            normalize_pixel(camera, pixel2.x(), pixel2.y()));
}

double ray_parallax_cosine(const SE3& T_c1w, const Eigen::Vector2d& x1, const SE3& T_c2w,
                           const Eigen::Vector2d& x2) {
  // Rays in the world frame: R_wc * (x, y, 1) = R_cw^T * (x, y, 1).
  const Eigen::Vector3d ray1 = T_c1w.linear().transpose() * x1.homogeneous();
  const Eigen::Vector3d ray2 = T_c2w.linear().transpose() * x2.homogeneous();
  return ray1.dot(ray2) / (ray1.norm() * ray2.norm());
}

double depth_in_camera(const SE3& T_cw, const Eigen::Vector3d& point_world) {
  return (T_cw * point_world).z();
}

bool has_positive_depth(const SE3& T_cw, const Eigen::Vector3d& point_world) {
  return depth_in_camera(T_cw, point_world) > 0.0;
}

bool reprojection_within(const StereoCamera& camera, const SE3& T_cw, const Eigen::Vector3d& point_world,
                         double u, double v, double sigma2, double chi2_threshold) {
  const Eigen::Vector3d p = T_cw * point_world;
  if (!(p.z() > 0.0)) return false;
  const double du = camera.fx * p.x() / p.z() + camera.cx - u;
  const double dv = camera.fy * p.y() / p.z() + camera.cy - v;
  return du * du + dv * dv <= chi2_threshold * sigma2;
}

bool stereo_reprojection_within(const StereoCamera& camera, const SE3& T_cw,
                                const Eigen::Vector3d& point_world, double u_left, double v, double u_right,
                                double sigma2, double chi2_threshold) {
  const Eigen::Vector3d p = T_cw * point_world;
  if (!(p.z() > 0.0)) return false;
  const double u_pred = camera.fx * p.x() / p.z() + camera.cx;
  const double du = u_pred - u_left;
  const double dv = camera.fy * p.y() / p.z() + camera.cy - v;
  const double dr = u_pred - camera.bf() / p.z() - u_right;
  return du * du + dv * dv + dr * dr <= chi2_threshold * sigma2;
}

std::optional<Eigen::Vector3d> triangulate_checked(const StereoCamera& camera, const TriangulationView& view1,
                                                   const TriangulationView& view2,
                                                   double max_parallax_cosine) {
  const Eigen::Vector2d x1 = normalize_pixel(camera, view1.pixel.x(), view1.pixel.y());
  const Eigen::Vector2d x2 = normalize_pixel(camera, view2.pixel.x(), view2.pixel.y());
  const double cos_parallax = ray_parallax_cosine(view1.T_cw, x1, view2.T_cw, x2);
  if (!(cos_parallax > 0.0 && cos_parallax < max_parallax_cosine)) return std::nullopt;
  const std::optional<Eigen::Vector3d> point = triangulate_linear(view1.T_cw, x1, view2.T_cw, x2);
  if (!point) return std::nullopt;
  if (!has_positive_depth(view1.T_cw, *point) || !has_positive_depth(view2.T_cw, *point)) return std::nullopt;
  if (!reprojection_within(camera, view1.T_cw, *point, view1.pixel.x(), view1.pixel.y(), view1.sigma2) ||
      !reprojection_within(camera, view2.T_cw, *point, view2.pixel.x(), view2.pixel.y(), view2.sigma2)) {
    return std::nullopt;
  }
  return point;
}

std::optional<Eigen::Vector3d> stereo_backproject_camera(const StereoCamera& camera, double u_left, double v,
                                                         double u_right) {
  const double disparity = u_left - u_right;
  if (!(disparity > 0.0)) return std::nullopt;
  const double z = camera.bf() / disparity;
  return Eigen::Vector3d((u_left - camera.cx) * z / camera.fx, (v - camera.cy) * z / camera.fy, z);
}

std::optional<Eigen::Vector3d> stereo_backproject_world(const StereoCamera& camera, const SE3& T_cw,
                                                        double u_left, double v, double u_right) {
  const std::optional<Eigen::Vector3d> p_c = stereo_backproject_camera(camera, u_left, v, u_right);
  if (!p_c) return std::nullopt;
  return T_cw.inverse() * *p_c;
}

}  // namespace porta::slam::optim
