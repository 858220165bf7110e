// Ceres settings shared by the optimisations in this folder (private to porta_optim).
#pragma once

#include <ceres/problem.h>
#include <ceres/solver.h>

namespace porta::slam::optim::detail {

// The caller owns cost functions, losses and manifolds (they outlive the rounds that rebuild the
// problem), so the problem must not delete them.
inline ceres::Problem::Options borrowing_problem_options() {
  ceres::Problem::Options options;
  options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

// Levenberg-Marquardt, quiet; the caller picks the linear solver and iteration count.
inline ceres::Solver::Options quiet_solver_options(int max_iterations, int num_threads) {
  ceres::Solver::Options options;
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.max_num_iterations = max_iterations;
  options.num_threads = num_threads;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  return options;
}

}  // namespace porta::slam::optim::detail
