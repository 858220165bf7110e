// Pose-only optimisation (ORB-SLAM2's PoseOptimization): refine one camera pose T_cw against fixed
// map points seen in the frame, classifying the observations as inliers and outliers.
//
// Rounds of Levenberg-Marquardt (default 4 x 10 iterations), each started from the initial pose
// (as ORB-SLAM2) over the observations currently classified as inliers, with a Huber loss of width
// sqrt(chi2 threshold) except in the last round(s). After each round every observation (outliers
// included) is re-classified by its chi2 at the new pose: chi2 > 5.991 (mono) / 7.815 (stereo), or
// the point not in front of the camera, makes it an outlier for the next round. Rounds stop early
// when fewer than `min_inliers_to_continue` inliers remain. Single-threaded and deterministic: the
// same input gives bit-identical output.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "porta/slam/optim/chi2.hpp"
#include "porta/slam/pose.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::optim {

/// A map point (fixed) and where the frame sees it.
struct PoseObservation {
  Eigen::Vector3d point_world = Eigen::Vector3d::Zero();
  double u_left = 0.0;    ///< pixels, left image
  double v = 0.0;         ///< pixels (rectified: same row in both images)
  double u_right = -1.0;  ///< pixels, right image; negative = mono (no stereo match), as ORB-SLAM2
  double sigma2 = 1.0;    ///< pixel variance of the keypoint's level: level_sigma2(level, scale)
  bool is_stereo() const { return u_right >= 0.0; }
};

struct PoseOptimizationOptions {
  int rounds = 4;
  int iterations_per_round = 10;
  int robust_rounds = 3;  ///< the first rounds use the Huber loss, the rest none (ORB-SLAM2: 3)
  double chi2_mono = kChi2Mono95;
  double chi2_stereo = kChi2Stereo95;
  int min_inliers_to_continue = 10;  ///< stop after a round that leaves fewer inliers (ORB-SLAM2: 10)
  /// true (the default): every round starts from the initial pose, as ORB-SLAM2. false: from the
  /// round before's result, the same pose to 0.01 mm in fewer passes where the inliers change
  /// between rounds (BM_PoseOptimization: 13 against 17), but inside SLAM, where repeated rounds
  /// are skipped, only 5 % fewer (docs/BENCHMARKS.md): not worth new deterministic bytes.
  bool restart_each_round = true;
  /// With restart_each_round: a round whose inliers and loss are those the round before was solved
  /// with would give that round's pose again, bit for bit, so it is not solved again. false solves
  /// every round (the same result; for tests).
  bool skip_repeated_rounds = true;
};

struct PoseOptimizationResult {
  SE3 T_cw = SE3::Identity();  ///< optimised pose (the initial one when not optimised)
  std::vector<bool> inlier;    ///< per observation, after the last round
  int num_inliers = 0;
  int rounds_run = 0;     ///< rounds completed, repeated ones included
  int rounds_solved = 0;  ///< of them, those solved (Levenberg-Marquardt run)
  int passes = 0;         ///< passes over the terms (each evaluates the cost and normal equations)
  bool optimized = false;  ///< false when there were fewer than 3 observations
};

/// Throws std::invalid_argument for an invalid camera or an observation with sigma2 <= 0.
PoseOptimizationResult optimize_pose(const StereoCamera& camera, const SE3& T_cw_initial,
                                     std::span<const PoseObservation> observations,
                                     const PoseOptimizationOptions& options = {});

}  // namespace porta::slam::optim
