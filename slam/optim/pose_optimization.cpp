// ORB-SLAM2-style pose-only optimisation on Ceres; see pose_optimization.hpp.
#include "porta/slam/optim/pose_optimization.hpp"

#include <ceres/loss_function.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "porta/slam/optim/reprojection_costs.hpp"
#include "porta/slam/optim/se3_manifold.hpp"
#include "solver_setup.hpp"

namespace porta::slam::optim {

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
  ceres::HuberLoss huber_mono(std::sqrt(options.chi2_mono));
  ceres::HuberLoss huber_stereo(std::sqrt(options.chi2_stereo));
  Se3Manifold manifold;

  const PoseParams initial = pose_to_params(T_cw_initial);
  PoseParams x = initial;
  std::vector<bool>& inlier = result.inlier;
  for (std::size_t i = 0; i < n; ++i) {  // a point behind the camera is an outlier from the start
    inlier[i] = transform_to_camera(x.data(), observations[i].point_world).z() > 0.0;
  }
  result.num_inliers = static_cast<int>(std::count(inlier.begin(), inlier.end(), true));

  for (int round = 0; round < options.rounds; ++round) {
    if (options.restart_each_round) x = initial;
    ceres::Problem problem(detail::borrowing_problem_options());
    problem.AddParameterBlock(x.data(), kPoseAmbientSize, &manifold);
    const bool robust = round < options.robust_rounds;
    int active = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!inlier[i]) continue;
      ceres::LossFunction* loss = nullptr;
      if (robust) loss = observations[i].is_stereo() ? &huber_stereo : &huber_mono;
      problem.AddResidualBlock(costs[i].get(), loss, x.data());
      ++active;
    }
    if (active < 3) break;

    ceres::Solver::Options solver_options = detail::quiet_solver_options(options.iterations_per_round, 1);
    solver_options.linear_solver_type = ceres::DENSE_QR;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
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
