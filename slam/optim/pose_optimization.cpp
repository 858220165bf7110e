// ORB-SLAM2-style pose-only optimisation; see pose_optimization.hpp.
//
// One 6-dof block against up to a few thousand residuals, solved ~80 times per tracked frame: a
// general solver's per-solve set-up costs more than the arithmetic, so the Levenberg-Marquardt
// loop is written out here (normal equations accumulated directly into a 6x6 system, the Huber loss
// as iteratively reweighted least squares, as g2o in ORB-SLAM2). The residuals and Jacobians are
// the same analytic cost functions the bundle adjustment gives Ceres (reprojection_costs.hpp).
#include "porta/slam/optim/pose_optimization.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "porta/slam/optim/reprojection_costs.hpp"
#include "porta/slam/optim/se3_manifold.hpp"
#include "huber_weight.hpp"

namespace porta::slam::optim {
namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Vector6 = Eigen::Matrix<double, 6, 1>;

/// Levenberg-Marquardt over the active observations, from `x`; at most `max_iterations` steps.
/// Stops when the relative cost decrease falls below 1e-6 or the step below 1e-10 (Ceres'
/// default tolerances).
void levenberg_marquardt(PoseParams& x, std::span<const PoseObservation> observations,
                         const std::vector<std::unique_ptr<ceres::CostFunction>>& costs,
                         const std::vector<bool>& active, bool robust, int max_iterations,
                         const PoseOptimizationOptions& options) {
  const Se3Manifold manifold;
  const std::size_t n = observations.size();
  const auto delta2 = [&](std::size_t i) { return observations[i].is_stereo() ? options.chi2_stereo : options.chi2_mono; };

  // Total robust cost at `params`; false when a residual cannot be evaluated.
  const auto total_cost = [&](const PoseParams& params, double& cost) {
    const double* const blocks[] = {params.data()};
    cost = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!active[i]) continue;
      double r[3] = {0.0, 0.0, 0.0};
      if (!costs[i]->Evaluate(blocks, r, nullptr)) return false;
      cost += detail::huber_weight(r[0] * r[0] + r[1] * r[1] + r[2] * r[2], delta2(i), robust).cost;
    }
    return true;
  };

  double cost = 0.0;
  if (!total_cost(x, cost)) return;
  double lambda = 1e-4;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    // Normal equations in the tangent space: J_tangent = J_ambient (rows x 7) * PlusJacobian (7 x 6).
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_jacobian;
    manifold.PlusJacobian(x.data(), plus_jacobian.data());
    Matrix6 H = Matrix6::Zero();
    Vector6 g = Vector6::Zero();
    const double* const blocks[] = {x.data()};
    for (std::size_t i = 0; i < n; ++i) {
      if (!active[i]) continue;
      const int rows = observations[i].is_stereo() ? 3 : 2;
      double r[3] = {0.0, 0.0, 0.0};
      Eigen::Matrix<double, 3, 7, Eigen::RowMajor> J_ambient = Eigen::Matrix<double, 3, 7, Eigen::RowMajor>::Zero();
      double* jacobians[] = {J_ambient.data()};
      if (!costs[i]->Evaluate(blocks, r, jacobians)) return;
      const detail::HuberWeight w = detail::huber_weight(r[0] * r[0] + r[1] * r[1] + r[2] * r[2], delta2(i), robust);
      const Eigen::Matrix<double, 3, 6> J = J_ambient * plus_jacobian;
      const Eigen::Vector3d residual(r[0], r[1], r[2]);
      H.noalias() += w.weight * J.topRows(rows).transpose() * J.topRows(rows);
      g.noalias() += w.weight * J.topRows(rows).transpose() * residual.head(rows);
    }
    if (g.lpNorm<Eigen::Infinity>() <= 1e-10) return;

    // Damped steps until one lowers the cost (Marquardt's diagonal scaling).
    bool accepted = false;
    for (int attempt = 0; attempt < 10 && !accepted; ++attempt) {
      Matrix6 damped = H;
      for (int k = 0; k < 6; ++k) damped(k, k) += lambda * std::max(H(k, k), 1e-6);
      const Vector6 step = damped.ldlt().solve(-g);
      if (!step.allFinite()) return;
      PoseParams candidate{};
      manifold.Plus(x.data(), step.data(), candidate.data());
      double candidate_cost = 0.0;
      if (total_cost(candidate, candidate_cost) && candidate_cost < cost) {
        const double decrease = (cost - candidate_cost) / std::max(cost, 1e-300);
        x = candidate;
        cost = candidate_cost;
        lambda = std::max(lambda / 3.0, 1e-12);
        accepted = true;
        if (decrease < 1e-6 || step.norm() < 1e-10) return;
      } else {
        lambda *= 4.0;
        if (step.norm() < 1e-10) return;
      }
    }
    if (!accepted) return;
  }
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
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  costs.reserve(n);
  for (const PoseObservation& o : observations) {
    const double sqrt_info = 1.0 / std::sqrt(o.sigma2);
    if (o.is_stereo()) {
      costs.push_back(std::make_unique<StereoPoseOnlyCost>(model, StereoMeasurement{o.u_left, o.v, o.u_right},
                                                           sqrt_info, o.point_world));
    } else {
      costs.push_back(std::make_unique<MonoPoseOnlyCost>(model, o.u_left, o.v, sqrt_info, o.point_world));
    }
  }

  const PoseParams initial = pose_to_params(T_cw_initial);
  PoseParams x = initial;
  std::vector<bool>& inlier = result.inlier;
  for (std::size_t i = 0; i < n; ++i) {  // a point behind the camera is an outlier from the start
    inlier[i] = transform_to_camera(x.data(), observations[i].point_world).z() > 0.0;
  }
  result.num_inliers = static_cast<int>(std::count(inlier.begin(), inlier.end(), true));

  for (int round = 0; round < options.rounds; ++round) {
    if (options.restart_each_round) x = initial;
    const bool robust = round < options.robust_rounds;
    if (std::count(inlier.begin(), inlier.end(), true) < 3) break;
    levenberg_marquardt(x, observations, costs, inlier, robust, options.iterations_per_round, options);
    ++result.rounds_run;
    result.optimized = true;

    // Re-classify every observation, the excluded ones too, at the new pose.
    int inliers = 0;
    const double* const params[] = {x.data()};
    for (std::size_t i = 0; i < n; ++i) {
      const PoseObservation& o = observations[i];
      double residual[3] = {0.0, 0.0, 0.0};
      const bool evaluated = costs[i]->Evaluate(params, residual, nullptr);
      const double chi2 = residual[0] * residual[0] + residual[1] * residual[1] + residual[2] * residual[2];
      const double threshold = o.is_stereo() ? options.chi2_stereo : options.chi2_mono;
      const bool in_front = transform_to_camera(x.data(), o.point_world).z() > 0.0;
      inlier[i] = evaluated && in_front && chi2 <= threshold;
      inliers += inlier[i] ? 1 : 0;
    }
    result.num_inliers = inliers;
    if (inliers < options.min_inliers_to_continue) break;
  }
  if (result.optimized) result.T_cw = params_to_pose(x.data());
  return result;
}

}  // namespace porta::slam::optim
