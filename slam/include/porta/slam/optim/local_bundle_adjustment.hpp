// Local bundle adjustment (ORB-SLAM2's LocalBundleAdjustment): jointly refine the poses of the
// free keyframes and the positions of the points they see, holding the fixed keyframes (those that
// see the points but lie outside the local window) still.
//
// Two stages, as ORB-SLAM2: `first_iterations` (5) of Levenberg-Marquardt with a Huber loss over all
// observations; then (unless `second_iterations` is 0: global bundle adjustment) every observation with chi2 above 5.991 (mono) / 7.815 (stereo), or whose point
// is not in front of its camera, is dropped, and `second_iterations` (10) more run without a robust
// loss. Finally all observations (dropped ones too) are checked again by the same test at the
// final estimate; those failing are returned so that the map can erase them. Points are eliminated
// first (Schur complement; see BaSolver). The `schur` solver's result is deterministic (bit-identical
// for the same input) on any number of threads; Ceres' with num_threads = 1. Fixed keyframes' poses
// are returned untouched (bit-identical copies).
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "porta/slam/optim/chi2.hpp"
#include "porta/slam/pose.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::optim {

struct BaKeyframe {
  SE3 T_cw = SE3::Identity();  ///< world -> camera
  bool fixed = false;
};

/// Keyframe `keyframe` sees point `point` at (u_left, v), and at u_right in the right image.
struct BaObservation {
  std::size_t keyframe = 0;
  std::size_t point = 0;
  double u_left = 0.0;
  double v = 0.0;
  double u_right = -1.0;  ///< negative = mono
  double sigma2 = 1.0;    ///< level_sigma2(level, scale_factor)
  bool is_stereo() const { return u_right >= 0.0; }
};

/// Who solves the Levenberg-Marquardt steps. All three minimise the same cost with Ceres' step
/// control and differ in the linear algebra (and so in the last bits).
enum class BaSolver {
  /// Ours (schur_solver.hpp): per-point Schur elimination into a dense reduced camera system, in
  /// fixed-size blocks. For a local window of tens of keyframes; ~3x faster than Ceres' DENSE_SCHUR.
  schur,
  /// Ceres' DENSE_SCHUR: the same algebra through Ceres (the reference the tests and the benchmark
  /// compare `schur` with).
  ceres_dense_schur,
  /// Ceres' SPARSE_SCHUR: for global bundle adjustment, where the reduced camera system of
  /// hundreds of keyframes is mostly zeros.
  ceres_sparse_schur,
};

/// Calls fn(i) once for every i in [0, n) on any threads, in any order, and returns when all have
/// returned (a thread pool's parallel_for, for instance).
using ParallelFor = std::function<void(std::int64_t n, const std::function<void(std::int64_t)>& fn)>;

struct LocalBundleAdjustmentOptions {
  int first_iterations = 5;
  int second_iterations = 10;
  double chi2_mono = kChi2Mono95;
  double chi2_stereo = kChi2Stereo95;
  /// A stage ends after an iteration that lowered the cost by at most this fraction of it
  /// (Ceres' function_tolerance; its default 1e-6), in (0, 1).
  double function_tolerance = 1e-6;
  /// Threads. Ceres' solvers: theirs (1 = deterministic). `schur`: a pool of this many for the
  /// call when `parallel_for` is empty (same result on any number; in [1, 256]).
  int num_threads = 1;
  /// `schur` only: where its loops over points, keyframes and blocks of the reduced camera system
  /// run (e.g. a pool the caller keeps, instead of one started per call). Its result does not
  /// depend on it. Empty: num_threads decides.
  ParallelFor parallel_for;
  BaSolver solver = BaSolver::schur;
  /// When set (e.g. by local mapping when a new keyframe arrives) the solver stops at its next
  /// iteration and the second stage is skipped; the outlier check still runs.
  const std::atomic<bool>* stop_flag = nullptr;
  /// Called after every solver iteration, before stop_flag is read; local mapping pauses there
  /// while tracking works (LocalMapper::tracking_started()). Empty: nothing.
  std::function<void()> between_iterations;
};

struct LocalBundleAdjustmentResult {
  std::vector<SE3> T_cw;                          ///< every keyframe; fixed ones are copies of the input
  std::vector<Eigen::Vector3d> points;            ///< every point; unobserved ones are copies of the input
  std::vector<std::size_t> outlier_observations;  ///< indices into the observations, ascending
  double initial_cost = 0.0;   ///< cost (1/2 sum of robustified chi2, as Ceres') before the first stage
  double final_cost = 0.0;     ///< cost at the end of the last stage run
  double final_rmse_px = 0.0;  ///< RMS pixel residual (unwhitened) over the inlier observations
  int iterations = 0;          ///< LM iterations of both stages
  double time_s = 0.0;
  bool stopped = false;  ///< the stop flag cut the optimisation short
};

/// Throws std::invalid_argument for an invalid camera or an observation naming a keyframe or point
/// that does not exist or with sigma2 <= 0.
LocalBundleAdjustmentResult local_bundle_adjustment(const StereoCamera& camera,
                                                    std::span<const BaKeyframe> keyframes,
                                                    std::span<const Eigen::Vector3d> points,
                                                    std::span<const BaObservation> observations,
                                                    const LocalBundleAdjustmentOptions& options = {});

}  // namespace porta::slam::optim
