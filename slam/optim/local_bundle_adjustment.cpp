// ORB-SLAM2-style local bundle adjustment: the two stages and the outlier test, the steps by our
// Schur solver (schur_solver.hpp) or by Ceres; see local_bundle_adjustment.hpp.
#include "porta/slam/optim/local_bundle_adjustment.hpp"

#include <ceres/iteration_callback.h>
#include <ceres/loss_function.h>
#include <ceres/ordered_groups.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

#include "cpu/thread_pool.hpp"
#include "porta/slam/optim/reprojection_costs.hpp"
#include "porta/slam/optim/se3_manifold.hpp"
#include "schur_solver.hpp"
#include "solver_setup.hpp"

namespace porta::slam::optim {
namespace {

/// After each iteration: the caller's hook, then its stop flag.
class IterationHooks final : public ceres::IterationCallback {
 public:
  IterationHooks(const std::atomic<bool>* flag, const std::function<void()>& between)
      : flag_(flag), between_(between) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    if (between_) between_();
    return flag_ != nullptr && flag_->load(std::memory_order_relaxed) ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                                                     : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* flag_;
  const std::function<void()>& between_;
};

constexpr int kMaxThreads = 256;

void validate_input(std::span<const BaKeyframe> keyframes, std::span<const Eigen::Vector3d> points,
                    std::span<const BaObservation> observations, const LocalBundleAdjustmentOptions& options) {
  if (options.num_threads < 1 || options.num_threads > kMaxThreads) {
    throw std::invalid_argument("local_bundle_adjustment: options.num_threads = " +
                                std::to_string(options.num_threads) + " (must be in [1, " +
                                std::to_string(kMaxThreads) + "])");
  }
  if (!(options.function_tolerance > 0.0 && options.function_tolerance < 1.0)) {
    throw std::invalid_argument("local_bundle_adjustment: options.function_tolerance = " +
                                std::to_string(options.function_tolerance) + " (must be in (0, 1))");
  }
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const BaObservation& o = observations[i];
    const std::string where = "local_bundle_adjustment: observation " + std::to_string(i);
    if (o.keyframe >= keyframes.size()) {
      throw std::invalid_argument(where + " names keyframe " + std::to_string(o.keyframe) + " of " +
                                  std::to_string(keyframes.size()));
    }
    if (o.point >= points.size()) {
      throw std::invalid_argument(where + " names point " + std::to_string(o.point) + " of " +
                                  std::to_string(points.size()));
    }
    if (!(o.sigma2 > 0.0) || !std::isfinite(o.sigma2)) {
      throw std::invalid_argument(where + " has sigma2 " + std::to_string(o.sigma2) +
                                  " (must be finite and > 0: level_sigma2())");
    }
  }
}

}  // namespace

LocalBundleAdjustmentResult local_bundle_adjustment(const StereoCamera& camera,
                                                    std::span<const BaKeyframe> keyframes,
                                                    std::span<const Eigen::Vector3d> points,
                                                    std::span<const BaObservation> observations,
                                                    const LocalBundleAdjustmentOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  camera.validate();
  validate_input(keyframes, points, observations, options);
  const std::size_t n = observations.size();

  LocalBundleAdjustmentResult result;
  result.T_cw.reserve(keyframes.size());
  for (const BaKeyframe& kf : keyframes) result.T_cw.push_back(kf.T_cw);
  result.points.assign(points.begin(), points.end());

  // Parameter storage the Ceres problems point into; rebuilt problems share it.
  std::vector<PoseParams> poses(keyframes.size());
  for (std::size_t k = 0; k < keyframes.size(); ++k) poses[k] = pose_to_params(keyframes[k].T_cw);
  std::vector<Eigen::Vector3d> xyz(points.begin(), points.end());

  const ProjectionModel model = ProjectionModel::from(camera);
  std::vector<double> sqrt_info(n);
  for (std::size_t i = 0; i < n; ++i) sqrt_info[i] = 1.0 / std::sqrt(observations[i].sigma2);
  // Ceres' cost functions, for Ceres' solvers only.
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  if (options.solver != BaSolver::schur) {
    costs.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const BaObservation& o = observations[i];
      if (o.is_stereo()) {
        costs.push_back(std::make_unique<StereoReprojectionCost>(
            model, StereoMeasurement{o.u_left, o.v, o.u_right}, sqrt_info[i]));
      } else {
        costs.push_back(std::make_unique<MonoReprojectionCost>(model, o.u_left, o.v, sqrt_info[i]));
      }
    }
  }
  ceres::HuberLoss huber_mono(std::sqrt(options.chi2_mono));
  ceres::HuberLoss huber_stereo(std::sqrt(options.chi2_stereo));
  Se3Manifold manifold;
  IterationHooks stop_callback(options.stop_flag, options.between_iterations);
  const auto stop_requested = [&] {
    return options.stop_flag != nullptr && options.stop_flag->load(std::memory_order_relaxed);
  };

  // The schur solver's loops: on the caller's parallel_for, else on a pool for this call.
  ParallelFor parallel_for = options.parallel_for;
  std::unique_ptr<cpu::ThreadPool> pool;
  if (!parallel_for && options.solver == BaSolver::schur && options.num_threads > 1) {
    pool = std::make_unique<cpu::ThreadPool>(options.num_threads, "porta-ba-pool");
    parallel_for = [&pool](std::int64_t count, const std::function<void(std::int64_t)>& fn) {
      pool->parallel_for(0, count, fn);
    };
  }
  // fn(i) for every observation, split over parallel_for when there is one (each writes its own).
  const auto for_each_observation = [&](const std::function<void(std::int64_t)>& fn) {
    if (parallel_for) {
      parallel_for(static_cast<std::int64_t>(n), fn);
    } else {
      for (std::size_t i = 0; i < n; ++i) fn(static_cast<std::int64_t>(i));
    }
  };

  // chi2 test of ORB-SLAM2 at the current estimate, per observation: whitened squared residual
  // under the threshold, point in front. The residual is the cost functions' (the same arithmetic:
  // the pose's rotation, then the camera model), with each keyframe's rotation computed once.
  std::vector<Eigen::Matrix3d> rotation(keyframes.size());
  std::vector<std::uint8_t> inlier(n);
  std::vector<double> pixel_sq(n);
  const auto test_observations = [&] {
    for (std::size_t k = 0; k < keyframes.size(); ++k) rotation[k] = pose_rotation(poses[k].data());
    for_each_observation([&](std::int64_t index) {
      const auto i = static_cast<std::size_t>(index);
      const BaObservation& o = observations[i];
      const PoseParams& x = poses[o.keyframe];
      const Eigen::Vector3d p = rotation[o.keyframe] * xyz[o.point] + Eigen::Vector3d(x[4], x[5], x[6]);
      double r[3] = {0.0, 0.0, 0.0};
      bool ok = false;
      if (o.is_stereo()) {
        const double measured[3] = {o.u_left, o.v, o.u_right};
        ok = camera_residual<3>(model, measured, sqrt_info[i], p, r, nullptr);
      } else {
        const double measured[2] = {o.u_left, o.v};
        ok = camera_residual<2>(model, measured, sqrt_info[i], p, r, nullptr);
      }
      const double chi2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
      pixel_sq[i] = chi2 * o.sigma2;
      const double threshold = o.is_stereo() ? options.chi2_stereo : options.chi2_mono;
      inlier[i] = ok && chi2 <= threshold && p.z() > 0.0;
    });
  };

  // One stage: true when there was something to optimise; `stopped` when the stop flag ended it.
  struct Stage {
    double initial_cost = 0.0, final_cost = 0.0;
    bool stopped = false;
  };
  std::vector<bool> pose_fixed(keyframes.size());
  for (std::size_t k = 0; k < keyframes.size(); ++k) pose_fixed[k] = keyframes[k].fixed;
  const auto run_schur_stage = [&](const std::vector<bool>& active, int iterations, bool robust, Stage* stage) {
    detail::SchurStage input;
    input.model = model;
    input.observations = observations;
    input.sqrt_information = sqrt_info;
    input.active = &active;
    input.pose_fixed = &pose_fixed;
    input.robust = robust;
    input.chi2_mono = options.chi2_mono;
    input.chi2_stereo = options.chi2_stereo;
    input.max_iterations = iterations;
    input.function_tolerance = options.function_tolerance;
    input.stop_flag = options.stop_flag;
    input.between_iterations = &options.between_iterations;
    input.parallel_for = &parallel_for;
    const detail::SchurSummary summary = detail::schur_levenberg_marquardt(input, poses, xyz);
    result.iterations += summary.iterations;
    *stage = {summary.initial_cost, summary.final_cost, summary.stopped};
    return summary.ran;
  };
  const auto run_ceres_stage = [&](const std::vector<bool>& active, int iterations, bool robust, Stage* stage) {
    ceres::Problem problem(detail::borrowing_problem_options());
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    std::vector<bool> pose_added(keyframes.size(), false);
    std::vector<bool> point_added(xyz.size(), false);
    int residual_blocks = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!active[i]) continue;
      const BaObservation& o = observations[i];
      double* pose = poses[o.keyframe].data();
      double* point = xyz[o.point].data();
      if (!pose_added[o.keyframe]) {
        pose_added[o.keyframe] = true;
        problem.AddParameterBlock(pose, kPoseAmbientSize, &manifold);
        if (keyframes[o.keyframe].fixed) problem.SetParameterBlockConstant(pose);
        ordering->AddElementToGroup(pose, 1);
      }
      if (!point_added[o.point]) {
        point_added[o.point] = true;
        problem.AddParameterBlock(point, 3);
        ordering->AddElementToGroup(point, 0);  // points first: eliminated by the Schur complement
      }
      ceres::LossFunction* loss = nullptr;
      if (robust) loss = o.is_stereo() ? &huber_stereo : &huber_mono;
      problem.AddResidualBlock(costs[i].get(), loss, pose, point);
      ++residual_blocks;
    }
    if (residual_blocks == 0) return false;
    ceres::Solver::Options solver_options = detail::quiet_solver_options(iterations, options.num_threads);
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.linear_solver_type =
        options.solver == BaSolver::ceres_sparse_schur ? ceres::SPARSE_SCHUR : ceres::DENSE_SCHUR;
    solver_options.linear_solver_ordering = ordering;
    if (options.stop_flag != nullptr || options.between_iterations) solver_options.callbacks.push_back(&stop_callback);
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    result.iterations += summary.num_successful_steps + summary.num_unsuccessful_steps;
    *stage = {summary.initial_cost, summary.final_cost, summary.termination_type == ceres::USER_SUCCESS};
    return true;
  };
  const auto run_stage = [&](const std::vector<bool>& active, int iterations, bool robust, Stage* stage) {
    return options.solver == BaSolver::schur ? run_schur_stage(active, iterations, robust, stage)
                                             : run_ceres_stage(active, iterations, robust, stage);
  };

  // Stage 1: robust, everything in front of its camera (a point behind it would project mirrored).
  std::vector<bool> active(n);
  {
    std::vector<std::uint8_t> in_front(n);
    for (std::size_t k = 0; k < keyframes.size(); ++k) rotation[k] = pose_rotation(poses[k].data());
    for_each_observation([&](std::int64_t index) {
      const auto i = static_cast<std::size_t>(index);
      const BaObservation& o = observations[i];
      const PoseParams& x = poses[o.keyframe];
      in_front[i] = (rotation[o.keyframe] * xyz[o.point] + Eigen::Vector3d(x[4], x[5], x[6])).z() > 0.0;
    });
    for (std::size_t i = 0; i < n; ++i) active[i] = in_front[i] != 0;
  }
  Stage stage;
  bool solved = false;
  if (stop_requested()) {
    result.stopped = true;
  } else {
    solved = run_stage(active, options.first_iterations, true, &stage);
    if (solved) result.initial_cost = stage.initial_cost;
  }
  // Stage 2: without the outliers of stage 1 and without the robust loss.
  if (solved && options.second_iterations > 0) {
    if (stage.stopped || stop_requested()) {
      result.stopped = true;
    } else {
      test_observations();
      for (std::size_t i = 0; i < n; ++i) active[i] = inlier[i] != 0;
      Stage second;
      if (run_stage(active, options.second_iterations, false, &second)) {
        stage = second;
        result.stopped = stage.stopped;
      }
    }
  }
  if (solved && options.second_iterations <= 0) result.stopped = stage.stopped;
  if (solved) result.final_cost = stage.final_cost;

  double sum_sq = 0.0;
  std::size_t coordinates = 0;
  test_observations();
  for (std::size_t i = 0; i < n; ++i) {
    if (inlier[i] != 0) {
      sum_sq += pixel_sq[i];
      coordinates += observations[i].is_stereo() ? 3 : 2;
    } else {
      result.outlier_observations.push_back(i);
    }
  }
  result.final_rmse_px = coordinates > 0 ? std::sqrt(sum_sq / static_cast<double>(coordinates)) : 0.0;

  if (solved) {
    std::vector<bool> point_seen(xyz.size(), false);
    std::vector<bool> pose_seen(keyframes.size(), false);
    for (const BaObservation& o : observations) {
      point_seen[o.point] = true;
      pose_seen[o.keyframe] = true;
    }
    for (std::size_t k = 0; k < keyframes.size(); ++k) {
      if (pose_seen[k] && !keyframes[k].fixed) result.T_cw[k] = params_to_pose(poses[k].data());
    }
    for (std::size_t p = 0; p < xyz.size(); ++p) {
      if (point_seen[p]) result.points[p] = xyz[p];
    }
  }
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace porta::slam::optim
