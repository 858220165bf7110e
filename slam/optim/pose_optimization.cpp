// ORB-SLAM2-style pose-only optimisation; see pose_optimization.hpp.
//
// One 6-dof block against up to a few thousand residuals, solved ~80 times per tracked frame: a
// general solver's per-solve set-up costs more than the arithmetic, so the Levenberg-Marquardt
// loop is written out here (normal equations accumulated directly into a 6x6 system, the Huber loss
// as iteratively reweighted least squares, as g2o in ORB-SLAM2). The residuals are the bundle
// adjustment's (camera_residual, reprojection_costs.hpp); the rotation is computed once per pass
// and the Jacobian taken in the tangent space directly (tracking's largest cost before: a virtual
// call, a quaternion-to-matrix conversion and a 3x7 by 7x6 product per observation and pass).
#include "porta/slam/optim/pose_optimization.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "porta/slam/optim/reprojection_costs.hpp"
#include "porta/slam/optim/se3_manifold.hpp"
#include "huber_weight.hpp"

namespace porta::slam::optim {
namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;

/// One observation as the loop reads it: the point, the measurement (u_l, v[, u_r]), the square
/// root of its information and its chi2 threshold (the Huber width's square).
struct Term {
  Vec3 X;
  double observation[3] = {0.0, 0.0, 0.0};
  double s = 1.0;
  double delta2 = 0.0;
  bool stereo = false;
};

/// The pose as every term needs it: the rotation once per pass, not once per term.
struct PoseAt {
  Mat3 R;
  Vec3 t;
  explicit PoseAt(const PoseParams& x) : R(pose_rotation(x.data())), t(x[4], x[5], x[6]) {}
};

/// Residual of `term` at the pose (3 rows; the third is 0 for a mono term) and its point in the
/// camera frame.
bool residual_at(const ProjectionModel& m, const Term& term, const PoseAt& pose, Vec3& p, Vec3& r) {
  p = pose.R * term.X + pose.t;
  if (term.stereo) return camera_residual<3>(m, term.observation, term.s, p, r.data(), nullptr);
  if (!camera_residual<2>(m, term.observation, term.s, p, r.data(), nullptr)) return false;
  r[2] = 0.0;
  return true;
}

/// Adds one term to the normal equations (upper triangle of H) and g. Its rows of the Jacobian are
/// the rows of D A, for D = dr/dp (camera_residual: rows (d00, 0, d02), (0, d11, d12), (d20, 0, d22),
/// the third all zero for a mono term) and A = [-[p]x  I], the left increment's dp / d[phi; rho]. So
/// with M = w D^T D (M01 = 0) and e = w D^T r the term adds
///   H += A^T M A = [ [p]x M [p]x^T   [p]x M ]      g += A^T e = [ p x e ]
///                  [ ([p]x M)^T      M      ],                  [   e   ],
/// 3x3 work in the camera's frame instead of a 6x6 outer product per row.
inline void add_term(const Vec3& p, double d00, double d02, double d11, double d12, double d20, double d22,
                     const Vec3& r, double w, Matrix6& H, Vector6& g) {
  const double a = w * (d00 * d00 + d20 * d20), b = w * (d00 * d02 + d20 * d22), c = w * (d11 * d11),
               d = w * (d11 * d12), f = w * (d02 * d02 + d12 * d12 + d22 * d22);
  const double e0 = w * (d00 * r[0] + d20 * r[2]), e1 = w * (d11 * r[1]),
               e2 = w * (d02 * r[0] + d12 * r[1] + d22 * r[2]);
  const double x = p.x(), y = p.y(), z = p.z();
  // K = [p]x M, column by column (p x M's columns (a, 0, b), (0, c, d), (b, d, f)).
  const double k00 = y * b, k10 = z * a - x * b, k20 = -y * a;
  const double k01 = y * d - z * c, k11 = -x * d, k21 = x * c;
  const double k02 = y * f - z * d, k12 = z * b - x * f, k22 = x * d - y * b;
  // [p]x M [p]x^T = -K [p]x: row i is p x (row i of K); its upper triangle.
  H(0, 0) += y * k02 - z * k01;
  H(0, 1) += z * k00 - x * k02;
  H(0, 2) += x * k01 - y * k00;
  H(1, 1) += z * k10 - x * k12;
  H(1, 2) += x * k11 - y * k10;
  H(2, 2) += x * k21 - y * k20;
  H(0, 3) += k00;
  H(0, 4) += k01;
  H(0, 5) += k02;
  H(1, 3) += k10;
  H(1, 4) += k11;
  H(1, 5) += k12;
  H(2, 3) += k20;
  H(2, 4) += k21;
  H(2, 5) += k22;
  H(3, 3) += a;
  H(3, 5) += b;
  H(4, 4) += c;
  H(4, 5) += d;
  H(5, 5) += f;
  g[0] += y * e2 - z * e1;
  g[1] += z * e0 - x * e2;
  g[2] += x * e1 - y * e0;
  g[3] += e0;
  g[4] += e1;
  g[5] += e2;
}

/// The robust cost of the active terms at `params` and, summed in the same pass, the normal
/// equations H (upper triangle, then mirrored) and g; false when a residual cannot be evaluated.
/// The Jacobian is taken in the tangent space directly: for the left increment T <- exp(d) T of
/// se3_manifold.hpp, d p / d [phi; rho] = [-[p]x  I], as the bundle adjustment's Schur solver does.
bool evaluate(const ProjectionModel& model, const std::vector<Term>& terms, const std::vector<bool>& active,
              bool robust, const PoseParams& params, double& cost, Matrix6& H, Vector6& g) {
  const PoseAt pose(params);
  cost = 0.0;
  H.setZero();
  g.setZero();
  Vec3 p, r;
  for (std::size_t i = 0; i < terms.size(); ++i) {
    if (!active[i]) continue;
    const Term& term = terms[i];
    if (!residual_at(model, term, pose, p, r)) return false;
    const detail::HuberWeight huber = detail::huber_weight(r.squaredNorm(), term.delta2, robust);
    cost += huber.cost;
    const double s = term.s;
    const double inv_z = 1.0 / p.z(), inv_z2 = inv_z * inv_z;
    const double du = -s * model.fx * inv_z;  // camera_residual's dr/dp entries
    const double d02 = s * model.fx * p.x() * inv_z2;
    const double d11 = -s * model.fy * inv_z, d12 = s * model.fy * p.y() * inv_z2;
    if (term.stereo) {
      add_term(p, du, d02, d11, d12, du, -s * (model.bf - model.fx * p.x()) * inv_z2, r, huber.weight, H, g);
    } else {
      add_term(p, du, d02, d11, d12, 0.0, 0.0, r, huber.weight, H, g);
    }
  }
  H.triangularView<Eigen::StrictlyLower>() = H.transpose();
  return true;
}

/// Levenberg-Marquardt over the active terms, from `x`; at most `max_iterations` steps. Stops when
/// the relative cost decrease falls below 1e-6 or the step below 1e-10 (Ceres' default tolerances).
/// A candidate's cost and its normal equations come from one pass (evaluate), so an accepted step
/// costs one pass over the terms, not two; the result is the same, bit for bit, as computing them
/// apart (the same sums in the same order).
/// Returns the passes over the terms it made.
int levenberg_marquardt(const ProjectionModel& model, PoseParams& x, const std::vector<Term>& terms,
                        const std::vector<bool>& active, bool robust, int max_iterations) {
  const Se3Manifold manifold;
  double cost = 0.0;
  Matrix6 H;
  Vector6 g;
  int passes = 1;
  if (!evaluate(model, terms, active, robust, x, cost, H, g)) return passes;
  double lambda = 1e-4;
  double candidate_cost = 0.0;
  Matrix6 candidate_H;
  Vector6 candidate_g;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    if (g.lpNorm<Eigen::Infinity>() <= 1e-10) return passes;

    // Damped steps until one lowers the cost (Marquardt's diagonal scaling).
    bool accepted = false;
    for (int attempt = 0; attempt < 10 && !accepted; ++attempt) {
      Matrix6 damped = H;
      for (int k = 0; k < 6; ++k) damped(k, k) += lambda * std::max(H(k, k), 1e-6);
      const Vector6 step = damped.ldlt().solve(-g);
      if (!step.allFinite()) return passes;
      PoseParams candidate{};
      manifold.Plus(x.data(), step.data(), candidate.data());
      ++passes;
      if (evaluate(model, terms, active, robust, candidate, candidate_cost, candidate_H, candidate_g) &&
          candidate_cost < cost) {
        const double decrease = (cost - candidate_cost) / std::max(cost, 1e-300);
        x = candidate;
        cost = candidate_cost;
        H = candidate_H;
        g = candidate_g;
        lambda = std::max(lambda / 3.0, 1e-12);
        accepted = true;
        if (decrease < 1e-6 || step.norm() < 1e-10) return passes;
      } else {
        lambda *= 4.0;
        if (step.norm() < 1e-10) return passes;
      }
    }
    if (!accepted) return passes;
  }
  return passes;
}

}  // namespace

PoseOptimizationResult optimize_pose(const StereoCamera& camera, const SE3& T_cw_initial,
                                     std::span<const PoseObservation> observations,
                                     const PoseOptimizationOptions& options) {
  camera.validate();
  const std::size_t n = observations.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double s2 = observations[i].sigma2;
    if (!(s2 > 0.0) || !std::isfinite(s2)) {
      throw std::invalid_argument("optimize_pose: observation " + std::to_string(i) + " has sigma2 " +
                                  std::to_string(s2) + " (must be finite and > 0: level_sigma2())");
    }
  }

  PoseOptimizationResult result;
  result.T_cw = T_cw_initial;
  result.inlier.assign(n, true);
  result.num_inliers = static_cast<int>(n);
  if (n < 3) return result;

  const ProjectionModel model = ProjectionModel::from(camera);
  std::vector<Term> terms(n);
  for (std::size_t i = 0; i < n; ++i) {
    const PoseObservation& o = observations[i];
    Term& term = terms[i];
    term.X = o.point_world;
    term.observation[0] = o.u_left;
    term.observation[1] = o.v;
    term.observation[2] = o.is_stereo() ? o.u_right : 0.0;
    term.s = 1.0 / std::sqrt(o.sigma2);
    term.stereo = o.is_stereo();
    term.delta2 = term.stereo ? options.chi2_stereo : options.chi2_mono;
  }

  const PoseParams initial = pose_to_params(T_cw_initial);
  PoseParams x = initial;
  std::vector<bool>& inlier = result.inlier;
  {
    const PoseAt pose(x);
    for (std::size_t i = 0; i < n; ++i) {  // a point behind the camera is an outlier from the start
      inlier[i] = (pose.R * terms[i].X + pose.t).z() > 0.0;
    }
  }
  result.num_inliers = static_cast<int>(std::count(inlier.begin(), inlier.end(), true));

  std::vector<bool> solved_with;  // the inliers the last solved round started from
  bool solved_robust = false;
  for (int round = 0; round < options.rounds; ++round) {
    const bool robust = round < options.robust_rounds;
    // From the same start, with the same terms and loss, the round before's result again: the
    // pose and the inliers stay as they are (the usual case once the inliers have settled).
    if (options.restart_each_round && options.skip_repeated_rounds && result.rounds_solved > 0 &&
        robust == solved_robust && inlier == solved_with) {
      ++result.rounds_run;
      continue;
    }
    if (options.restart_each_round) x = initial;
    if (std::count(inlier.begin(), inlier.end(), true) < 3) break;
    solved_with = inlier;
    solved_robust = robust;
    result.passes += levenberg_marquardt(model, x, terms, inlier, robust, options.iterations_per_round);
    ++result.rounds_run;
    ++result.rounds_solved;
    result.optimized = true;

    // Re-classify every observation, the excluded ones too, at the new pose.
    int inliers = 0;
    const PoseAt pose(x);
    Vec3 p, r;
    for (std::size_t i = 0; i < n; ++i) {
      const bool evaluated = residual_at(model, terms[i], pose, p, r);
      inlier[i] = evaluated && p.z() > 0.0 && r.squaredNorm() <= terms[i].delta2;
      inliers += inlier[i] ? 1 : 0;
    }
    result.num_inliers = inliers;
    if (inliers < options.min_inliers_to_continue) break;
  }
  if (result.optimized) result.T_cw = params_to_pose(x.data());
  return result;
}

}  // namespace porta::slam::optim
