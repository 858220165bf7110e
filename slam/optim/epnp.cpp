// EPnP (Lepetit, Moreno-Noguer, Fua, "EPnP: An Accurate O(n) Solution to the PnP Problem", IJCV
// 2009), written from the paper's description; see pnp.hpp for the contract. Notation follows the
// paper: control points c_j, barycentric weights alpha_ij, null-space vectors v_k, weights beta_k.
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "porta/slam/optim/pnp.hpp"
#include "porta/slam/optim/rigid_alignment.hpp"

namespace porta::slam::optim {
namespace {

using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

// Ratios of the world points' covariance eigenvalues (squared spreads). Below kCollinearRatio the
// second axis is noise and the pose about the line is undetermined (the same bound as align_rigid);
// below kPlanarRatio the points lie in a plane to ~1e-4 of their extent, and a fourth control point
// off that plane would make the barycentric system ill-conditioned: the paper's planar variant
// (3 control points) is used instead.
constexpr double kCollinearRatio = 1e-9;
constexpr double kPlanarRatio = 1e-8;
// The beta refinement has at most 4 unknowns and converges quadratically near the solution; a
// fixed cap (the best iterate is kept) bounds the cost inside RANSAC.
constexpr int kGaussNewtonIterations = 10;
// Squared pixel error charged to a point behind the camera when ranking candidates, so that a
// mirrored solution never beats one in front of the camera.
constexpr double kBehindCameraPenaltyPx2 = 1e10;

// Control points in the world and every point's barycentric weights (sum_j alpha_ij = 1).
struct ControlPoints {
  int count = 0;                  // 4, or 3 for coplanar points
  std::array<Vector3d, 4> world;  // c_0 = centroid, c_j = c_0 + sqrt(lambda_j) e_j
  MatrixXd alphas;                // n x count
};

std::optional<ControlPoints> choose_control_points(std::span<const Vector3d> points) {
  const double n = static_cast<double>(points.size());
  Vector3d centroid = Vector3d::Zero();
  for (const Vector3d& p : points) centroid += p;
  centroid /= n;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Vector3d& p : points) covariance += (p - centroid) * (p - centroid).transpose();
  covariance /= n;
  if (!covariance.allFinite()) return std::nullopt;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(covariance);
  const Vector3d& lambda = eig.eigenvalues();  // ascending
  if (!(lambda(2) > 0.0) || !(lambda(1) > kCollinearRatio * lambda(2))) return std::nullopt;

  ControlPoints cp;
  cp.count = lambda(0) > kPlanarRatio * lambda(2) ? 4 : 3;
  cp.world[0] = centroid;
  std::array<Vector3d, 3>
      axis_over_spread;  // e_j / s_j: the axes are orthogonal, so alpha_j = e_j.(p - c_0) / s_j
  for (int j = 1; j < cp.count; ++j) {
    const Vector3d axis = eig.eigenvectors().col(3 - j);  // largest spread first
    const double spread = std::sqrt(lambda(3 - j));
    cp.world[j] = centroid + spread * axis;
    axis_over_spread[j - 1] = axis / spread;
  }
  cp.alphas.resize(static_cast<Eigen::Index>(points.size()), cp.count);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    double sum = 0.0;
    for (int j = 1; j < cp.count; ++j) {
      cp.alphas(row, j) = axis_over_spread[j - 1].dot(points[i] - centroid);
      sum += cp.alphas(row, j);
    }
    cp.alphas(row, 0) = 1.0 - sum;
  }
  return cp;
}

// M^T M of the 2n x 3K system M x = 0 in the camera-frame control points x = [c_0^c; ...]. Each
// pixel gives two rows, sum_j alpha_ij (c_j^c.x - x_i c_j^c.z) = 0 and the same in y, with (x_i, y_i)
// the normalised coordinates (the paper's pixel rows divided by fx and fy: better conditioned).
MatrixXd projection_normal_matrix(const ControlPoints& cp, std::span<const Eigen::Vector2d> uv,
                                  const StereoCamera& camera) {
  const int cols = 3 * cp.count;
  MatrixXd MtM = MatrixXd::Zero(cols, cols);
  VectorXd row_x(cols), row_y(cols);
  for (std::size_t i = 0; i < uv.size(); ++i) {
    const double x = (uv[i].x() - camera.cx) / camera.fx;
    const double y = (uv[i].y() - camera.cy) / camera.fy;
    row_x.setZero();
    row_y.setZero();
    for (int j = 0; j < cp.count; ++j) {
      const double a = cp.alphas(static_cast<Eigen::Index>(i), j);
      row_x(3 * j) = a;
      row_x(3 * j + 2) = -a * x;
      row_y(3 * j + 1) = a;
      row_y(3 * j + 2) = -a * y;
    }
    MtM.selfadjointView<Eigen::Lower>().rankUpdate(row_x);
    MtM.selfadjointView<Eigen::Lower>().rankUpdate(row_y);
  }
  return MtM.selfadjointView<Eigen::Lower>();
}

// The distance constraints |c_a^c - c_b^c|^2 = |c_a^w - c_b^w|^2 over all control point pairs, with
// c^c = sum_k beta_k v_k: diff[p][k] = v_k's block a minus its block b for pair p.
struct DistanceConstraints {
  std::vector<std::array<Vector3d, 4>> diff;
  std::vector<double> world_distance2;
};

DistanceConstraints distance_constraints(const ControlPoints& cp, const MatrixXd& null_vectors, int N) {
  DistanceConstraints dc;
  for (int a = 0; a < cp.count; ++a) {
    for (int b = a + 1; b < cp.count; ++b) {
      std::array<Vector3d, 4> d{};
      for (int k = 0; k < N; ++k)
        d[k] = null_vectors.col(k).segment<3>(3 * a) - null_vectors.col(k).segment<3>(3 * b);
      dc.diff.push_back(d);
      dc.world_distance2.push_back((cp.world[a] - cp.world[b]).squaredNorm());
    }
  }
  return dc;
}

// Linearised betas: |sum_k beta_k d_k|^2 is linear in the products beta_kl. N = 1 uses the paper's
// closed form; N = 2, 3 solve for all products by least squares (3 and 6 unknowns, 6 equations;
// 3 with 3 for planar scenes). Square roots take the magnitude, signs relative to beta_0 come from
// the products beta_0k; the overall sign is fixed later by the depths.
VectorXd linearised_betas(const DistanceConstraints& dc, int N) {
  const auto P = static_cast<Eigen::Index>(dc.diff.size());
  VectorXd betas = VectorXd::Zero(N);
  if (N == 1) {
    double num = 0.0, den = 0.0;
    for (Eigen::Index p = 0; p < P; ++p) {
      num += dc.diff[p][0].norm() * std::sqrt(dc.world_distance2[p]);
      den += dc.diff[p][0].squaredNorm();
    }
    betas(0) = den > 0.0 ? num / den : 0.0;
    return betas;
  }
  std::vector<std::array<int, 2>> products;  // (k, l), k <= l
  for (int k = 0; k < N; ++k)
    for (int l = k; l < N; ++l) products.push_back({k, l});
  MatrixXd L(P, static_cast<Eigen::Index>(products.size()));
  VectorXd rho(P);
  for (Eigen::Index p = 0; p < P; ++p) {
    for (std::size_t c = 0; c < products.size(); ++c) {
      const auto [k, l] = products[c];  // off-diagonal products appear twice in the square
      L(p, static_cast<Eigen::Index>(c)) = (k == l ? 1.0 : 2.0) * dc.diff[p][k].dot(dc.diff[p][l]);
    }
    rho(p) = dc.world_distance2[p];
  }
  const VectorXd b = L.colPivHouseholderQr().solve(rho);
  const auto product = [&](int k, int l) {
    for (std::size_t c = 0; c < products.size(); ++c)
      if (products[c][0] == k && products[c][1] == l) return b(static_cast<Eigen::Index>(c));
    return 0.0;
  };
  betas(0) = std::sqrt(std::abs(product(0, 0)));
  for (int k = 1; k < N; ++k) betas(k) = std::copysign(std::sqrt(std::abs(product(k, k))), product(0, k));
  return betas;
}

// N = 4 (the paper's relinearisation): 10 products beta_kl and only 6 equations, so the products
// are b = b_0 + sum_i lambda_i n_i over L's 4-dimensional null space. The products of one beta
// vector form a rank-1 matrix B = beta beta^T, so every 2x2 minor B_ij B_kl - B_il B_kj vanishes:
// 36 equations, linear in the 15 products lambda_p lambda_q (lambda_0 = 1), solved by least squares.
// beta is then B's rank-1 part: sqrt(largest eigenvalue) times its eigenvector.
VectorXd relinearised_betas(const DistanceConstraints& dc) {
  constexpr int kProducts = 10, kLambdas = 5;
  std::array<std::array<int, 4>, 4> product_index{};  // symmetric (k, l) -> column of L
  for (int k = 0, c = 0; k < 4; ++k)
    for (int l = k; l < 4; ++l, ++c) product_index[k][l] = product_index[l][k] = c;
  const auto P = static_cast<Eigen::Index>(dc.diff.size());
  MatrixXd L = MatrixXd::Zero(P, kProducts);
  VectorXd rho(P);
  for (Eigen::Index p = 0; p < P; ++p) {
    for (int k = 0; k < 4; ++k)
      for (int l = k; l < 4; ++l)
        L(p, product_index[k][l]) = (k == l ? 1.0 : 2.0) * dc.diff[p][k].dot(dc.diff[p][l]);
    rho(p) = dc.world_distance2[p];
  }
  const Eigen::JacobiSVD<MatrixXd> svd(L, Eigen::ComputeFullU | Eigen::ComputeFullV);
  std::array<VectorXd, kLambdas> basis;  // b = basis[0] + sum_i lambda_i basis[i]
  basis[0] = svd.solve(rho);
  for (int i = 1; i < kLambdas; ++i) basis[i] = svd.matrixV().col(kProducts - kLambdas + i);

  std::array<std::array<int, kLambdas>, kLambdas> lambda_index{};  // symmetric (p, q) -> monomial
  for (int p = 0, m = 0; p < kLambdas; ++p)
    for (int q = p; q < kLambdas; ++q, ++m) lambda_index[p][q] = lambda_index[q][p] = m;
  MatrixXd minors = MatrixXd::Zero(36, 15);
  int row = 0;
  for (int i = 0; i < 4; ++i)
    for (int k = i + 1; k < 4; ++k)
      for (int j = 0; j < 4; ++j)
        for (int l = j + 1; l < 4; ++l, ++row)
          for (int p = 0; p < kLambdas; ++p)
            for (int q = 0; q < kLambdas; ++q)
              minors(row, lambda_index[p][q]) +=
                  basis[p](product_index[i][j]) * basis[q](product_index[k][l]) -
                  basis[p](product_index[i][l]) * basis[q](product_index[k][j]);
  // Monomial 0 is lambda_0^2 = 1: its column moves to the right-hand side.
  const VectorXd monomials = minors.rightCols(14).colPivHouseholderQr().solve(-minors.col(0));
  VectorXd b = basis[0];
  for (int i = 1; i < kLambdas; ++i) b += monomials(lambda_index[0][i] - 1) * basis[i];
  Eigen::Matrix4d B;
  for (int k = 0; k < 4; ++k)
    for (int l = 0; l < 4; ++l) B(k, l) = b(product_index[k][l]);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> rank1(B);
  return std::sqrt(std::max(rank1.eigenvalues()(3), 0.0)) * rank1.eigenvectors().col(3);
}

double distance_residual_norm2(const DistanceConstraints& dc, const VectorXd& betas, VectorXd* residual,
                               MatrixXd* jacobian) {
  const auto N = betas.size();
  double sum = 0.0;
  for (std::size_t p = 0; p < dc.diff.size(); ++p) {
    Vector3d d = Vector3d::Zero();
    for (Eigen::Index k = 0; k < N; ++k) d += betas(k) * dc.diff[p][k];
    const double r = d.squaredNorm() - dc.world_distance2[p];
    sum += r * r;
    if (residual) (*residual)(static_cast<Eigen::Index>(p)) = r;
    if (jacobian)
      for (Eigen::Index k = 0; k < N; ++k)
        (*jacobian)(static_cast<Eigen::Index>(p), k) = 2.0 * d.dot(dc.diff[p][k]);
  }
  return sum;
}

// Gauss-Newton on the betas against the distance residuals; returns the best iterate seen.
VectorXd refine_betas(const DistanceConstraints& dc, VectorXd betas) {
  const auto P = static_cast<Eigen::Index>(dc.diff.size());
  VectorXd residual(P);
  MatrixXd jacobian(P, betas.size());
  double best_cost = distance_residual_norm2(dc, betas, &residual, &jacobian);
  VectorXd best = betas;
  for (int it = 0; it < kGaussNewtonIterations && best_cost > 0.0; ++it) {
    betas -= jacobian.colPivHouseholderQr().solve(residual);
    const double cost = distance_residual_norm2(dc, betas, &residual, &jacobian);
    if (!std::isfinite(cost)) break;
    if (cost < best_cost) {
      best_cost = cost;
      best = betas;
    }
  }
  return best;
}

double reprojection_error_px2(std::span<const Vector3d> points_world, std::span<const Eigen::Vector2d> uv,
                              const StereoCamera& camera, const SE3& T_cw) {
  double sum = 0.0;
  for (std::size_t i = 0; i < points_world.size(); ++i) {
    const Vector3d p = T_cw * points_world[i];
    if (!(p.z() > 0.0)) {
      sum += kBehindCameraPenaltyPx2;
      continue;
    }
    const double du = camera.fx * p.x() / p.z() + camera.cx - uv[i].x();
    const double dv = camera.fy * p.y() / p.z() + camera.cy - uv[i].y();
    sum += du * du + dv * dv;
  }
  return sum;
}

// The pose of one beta solution: camera-frame control points sum_k beta_k v_k, the points from their
// barycentric weights, then the rigid motion from the world points onto them.
std::optional<SE3> pose_from_betas(const ControlPoints& cp, const MatrixXd& null_vectors,
                                   const VectorXd& betas, std::span<const Vector3d> points_world,
                                   std::vector<Vector3d>& points_camera) {
  std::array<Vector3d, 4> control_camera{};
  for (int j = 0; j < cp.count; ++j) {
    control_camera[j] = Vector3d::Zero();
    for (Eigen::Index k = 0; k < betas.size(); ++k)
      control_camera[j] += betas(k) * null_vectors.col(k).segment<3>(3 * j);
  }
  double depth_sum = 0.0;
  for (std::size_t i = 0; i < points_world.size(); ++i) {
    points_camera[i] = Vector3d::Zero();
    for (int j = 0; j < cp.count; ++j)
      points_camera[i] += cp.alphas(static_cast<Eigen::Index>(i), j) * control_camera[j];
    depth_sum += points_camera[i].z();
  }
  // The null space fixes the control points up to sign: the scene must lie in front of the camera.
  if (depth_sum < 0.0)
    for (Vector3d& p : points_camera) p = -p;
  return align_rigid(points_world, points_camera);
}

}  // namespace

std::optional<SE3> solve_epnp(std::span<const Vector3d> points_world, std::span<const Eigen::Vector2d> uv,
                              const StereoCamera& camera) {
  if (points_world.size() != uv.size() || points_world.size() < 4) return std::nullopt;
  const std::optional<ControlPoints> cp = choose_control_points(points_world);
  if (!cp) return std::nullopt;
  const MatrixXd MtM = projection_normal_matrix(*cp, uv, camera);
  if (!MtM.allFinite()) return std::nullopt;
  // Eigenvectors of M^T M with the smallest eigenvalues span (approximately) M's null space, in
  // which the true control points lie; eigenvalues come sorted ascending.
  const Eigen::SelfAdjointEigenSolver<MatrixXd> eig(MtM);
  if (eig.info() != Eigen::Success) return std::nullopt;
  const MatrixXd& null_vectors = eig.eigenvectors();

  // N = 3 needs the 6 products of 3 betas from as many equations: only with 4 control points (6
  // pairs); the planar case (3 pairs) stops at N = 2, as in the paper.
  const int max_N = cp->count == 4 ? 4 : 2;
  std::vector<Vector3d> points_camera(points_world.size());
  std::optional<SE3> best;
  double best_error = std::numeric_limits<double>::infinity();
  for (int N = 1; N <= max_N; ++N) {
    const DistanceConstraints dc = distance_constraints(*cp, null_vectors, N);
    const VectorXd betas = refine_betas(dc, N == 4 ? relinearised_betas(dc) : linearised_betas(dc, N));
    const std::optional<SE3> T_cw = pose_from_betas(*cp, null_vectors, betas, points_world, points_camera);
    if (!T_cw) continue;
    const double error = reprojection_error_px2(points_world, uv, camera, *T_cw);
    if (error < best_error) {  // strictly smaller: ties keep the smaller N
      best_error = error;
      best = T_cw;
    }
  }
  return best;
}

}  // namespace porta::slam::optim
