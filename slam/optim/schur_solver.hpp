// Levenberg-Marquardt for the bundle adjustment of a local window, written out for its shape
// (private to porta_optim; local_bundle_adjustment.hpp is the interface).
//
// Poses (6 tangent dof, se3_manifold.hpp's left increment) and points (3) in blocks of fixed size;
// the points are eliminated per point (Schur complement) into a dense reduced camera system of the
// free keyframes, solved by Cholesky. This is what Ceres' DENSE_SCHUR computes, without its costs
// that do not fit this problem: mixed 2- and 3-row residuals send Ceres to its dynamic-size
// eliminator, and it rebuilds its program per solve. The step control is Ceres' Levenberg-Marquardt
// (trust radius 1e4, diagonal clamped to [1e-6, 1e32], a step kept when it achieves 1e-3 of the
// predicted decrease; function tolerance the caller's (Ceres' 1e-6 by default), parameter
// tolerance 1e-8, gradient tolerance 1e-10),
// and a robust loss is applied as Ceres and g2o do with Huber: each residual block weighted by
// rho'(chi2). Every sum is taken in one fixed order (schur_layout.hpp) however the work is split
// over threads: the same input gives the same bits, on one thread or many.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <functional>
#include <span>
#include <vector>

#include "porta/slam/optim/local_bundle_adjustment.hpp"
#include "porta/slam/optim/reprojection_costs.hpp"
#include "porta/slam/optim/se3_manifold.hpp"

namespace porta::slam::optim::detail {

struct SchurStage {
  ProjectionModel model;
  std::span<const BaObservation> observations;
  std::span<const double> sqrt_information;  ///< per observation: 1 / sigma
  const std::vector<bool>* active = nullptr;  ///< per observation: part of this stage
  const std::vector<bool>* pose_fixed = nullptr;  ///< per keyframe
  bool robust = true;  ///< Huber of width sqrt(chi2_mono) / sqrt(chi2_stereo)
  double chi2_mono = 0.0, chi2_stereo = 0.0;
  int max_iterations = 0;  ///< steps tried, kept or not (Ceres' count)
  double function_tolerance = 1e-6;  ///< a kept step lowering the cost by at most this fraction ends it
  const std::atomic<bool>* stop_flag = nullptr;
  const std::function<void()>* between_iterations = nullptr;
  const ParallelFor* parallel_for = nullptr;  ///< null or empty: everything on the calling thread
};

struct SchurSummary {
  bool ran = false;  ///< there was something to optimise
  double initial_cost = 0.0, final_cost = 0.0;  ///< 1/2 sum of (robustified) chi2
  int iterations = 0;
  bool stopped = false;  ///< the stop flag ended it
};

/// Minimises the stage's cost over the free poses and every point an active observation sees,
/// updating `poses` and `points` in place.
SchurSummary schur_levenberg_marquardt(const SchurStage& stage, std::vector<PoseParams>& poses,
                                       std::vector<Eigen::Vector3d>& points);

}  // namespace porta::slam::optim::detail
