// Pose-only optimisation (ORB-SLAM2's PoseOptimization) on a synthetic frame: recovers a perturbed
// pose from stereo and mono observations with pixel noise, separates injected gross outliers,
// treats points behind the camera as outliers, and is bit-for-bit repeatable.
#if PORTA_OPTIM_BUILT

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

#include "porta/slam/optim/pose_optimization.hpp"

namespace porta::slam::optim {
namespace {

using Eigen::Vector3d;

StereoCamera test_camera() { return StereoCamera{640, 480, 500.0, 500.0, 320.0, 240.0, 0.12}; }

SE3 true_pose() {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(0.3, Vector3d(0.2, 1.0, -0.1).normalized()).toRotationMatrix();
  T.translation() = Vector3d(0.4, -0.2, 1.5);
  return T;
}

// T_cw moved by `translation_m` along a fixed direction and rotated by `angle_deg` about a fixed axis.
SE3 perturbed(const SE3& T, double translation_m, double angle_deg) {
  SE3 delta = SE3::Identity();
  delta.linear() =
      Eigen::AngleAxisd(angle_deg * std::numbers::pi / 180.0, Vector3d(1.0, -0.5, 0.7).normalized())
          .toRotationMatrix();
  delta.translation() = translation_m * Vector3d(0.6, 0.3, -0.74).normalized();
  return delta * T;
}

double translation_error_m(const SE3& a, const SE3& b) {  // camera centres
  return (a.inverse().translation() - b.inverse().translation()).norm();
}
double rotation_error_deg(const SE3& a, const SE3& b) {
  return rotation_angle_rad(a.linear() * b.linear().transpose()) * 180.0 / std::numbers::pi;
}

struct Frame {
  std::vector<PoseObservation> observations;
  std::vector<bool> is_outlier;  // injected
};

// `count` points seen by the camera at T_cw at depths 2..25 m, 60% with a stereo match; levels 0..3
// of a 1.2 pyramid. The measurement noise is 1 px whatever the level (ORB-SLAM2's sigma per level is
// an upper bound for sub-pixel keypoints), so the chi2 test keeps nearly all true inliers (a noise
// level equal to sigma would lose 5% of them by the definition of the 95% quantile).
Frame synthetic_frame(const StereoCamera& cam, const SE3& T_cw, int count, double outlier_fraction,
                      unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  Frame frame;
  const SE3 T_wc = T_cw.inverse();
  for (int i = 0; i < count; ++i) {
    const double u = 20.0 + uniform(rng) * (cam.width - 40.0);
    const double v = 20.0 + uniform(rng) * (cam.height - 40.0);
    const double z = 2.0 + uniform(rng) * 23.0;
    const Vector3d p_c((u - cam.cx) * z / cam.fx, (v - cam.cy) * z / cam.fy, z);
    PoseObservation o;
    o.point_world = T_wc * p_c;
    o.sigma2 = level_sigma2(static_cast<int>(uniform(rng) * 4.0), 1.2);
    o.u_left = u + noise(rng);
    o.v = v + noise(rng);
    const bool stereo = uniform(rng) < 0.6;
    if (stereo) o.u_right = u - cam.bf() / z + noise(rng);
    const bool outlier = uniform(rng) < outlier_fraction;
    if (outlier) {  // a wrong match: 20..80 px away in a random direction
      const double angle = 2.0 * std::numbers::pi * uniform(rng);
      const double distance = 20.0 + 60.0 * uniform(rng);
      o.u_left += distance * std::cos(angle);
      o.v += distance * std::sin(angle);
      if (stereo) o.u_right += distance * std::cos(angle);
    }
    frame.observations.push_back(o);
    frame.is_outlier.push_back(outlier);
  }
  return frame;
}

// Restarting every round from the initial pose (ORB-SLAM2), a round whose inliers and loss equal
// those the round before was solved with is not solved again
// (PoseOptimizationOptions::skip_repeated_rounds): the same pose and inliers, bit for bit.
TEST(OptimPoseOnly, RepeatedRoundsAreSkippedWithTheSameResult) {
  const StereoCamera cam = test_camera();
  const SE3 truth = true_pose();
  int skipped = 0;
  for (const unsigned seed : {7u, 8u, 9u, 10u}) {
    const Frame frame = synthetic_frame(cam, truth, 200, seed == 10u ? 0.0 : 0.15, seed);
    const SE3 initial = perturbed(truth, 0.05, 1.0);
    PoseOptimizationOptions restarting;
    restarting.restart_each_round = true;
    PoseOptimizationOptions every = restarting;
    every.skip_repeated_rounds = false;
    const PoseOptimizationResult all = optimize_pose(cam, initial, frame.observations, every);
    const PoseOptimizationResult fewer = optimize_pose(cam, initial, frame.observations, restarting);
    EXPECT_EQ(all.rounds_solved, all.rounds_run);
    EXPECT_EQ(fewer.rounds_run, all.rounds_run);
    EXPECT_EQ(std::memcmp(all.T_cw.data(), fewer.T_cw.data(), sizeof(double) * 16), 0) << "seed " << seed;
    EXPECT_EQ(all.inlier, fewer.inlier);
    EXPECT_EQ(all.num_inliers, fewer.num_inliers);
    skipped += fewer.rounds_run - fewer.rounds_solved;
  }
  EXPECT_GT(skipped, 0) << "no round was a repeat: the case is not exercised";
}

// Each round from the round before's pose (restart_each_round = false) ends where restarting from
// the initial pose (the default) ends: the same inliers, the pose to 0.1 mm and 0.001 degrees, in
// fewer passes.
TEST(OptimPoseOnly, EachRoundFromTheLastGivesTheRestartedPoseInFewerPasses) {
  const StereoCamera cam = test_camera();
  const SE3 truth = true_pose();
  int passes_restarted = 0, passes_continued = 0;
  for (const unsigned seed : {7u, 8u, 9u, 10u, 11u}) {
    const Frame frame = synthetic_frame(cam, truth, 200, seed == 10u ? 0.0 : 0.15, seed);
    const SE3 initial = perturbed(truth, 0.05, 1.0);
    PoseOptimizationOptions from_last;
    from_last.restart_each_round = false;
    const PoseOptimizationResult restarted = optimize_pose(cam, initial, frame.observations);
    const PoseOptimizationResult continued = optimize_pose(cam, initial, frame.observations, from_last);
    ASSERT_TRUE(continued.optimized);
    EXPECT_EQ(continued.inlier, restarted.inlier) << "seed " << seed;
    EXPECT_LT(translation_error_m(continued.T_cw, restarted.T_cw), 1e-4) << "seed " << seed;
    EXPECT_LT(rotation_error_deg(continued.T_cw, restarted.T_cw), 1e-3) << "seed " << seed;
    passes_restarted += restarted.passes;
    passes_continued += continued.passes;
  }
  EXPECT_LT(passes_continued, passes_restarted);
  std::printf("passes over the terms, 5 frames: %d restarting each round, %d from the last\n", passes_restarted,
              passes_continued);
}

TEST(OptimPoseOnly, RecoversPerturbedPoseAndSeparatesOutliers) {
  const StereoCamera cam = test_camera();
  const SE3 truth = true_pose();
  const Frame frame = synthetic_frame(cam, truth, 200, 0.15, 7);
  const SE3 initial = perturbed(truth, 0.10, 3.0);
  ASSERT_NEAR(translation_error_m(initial, truth), 0.10, 0.05);

  const PoseOptimizationResult result = optimize_pose(cam, initial, frame.observations);
  ASSERT_TRUE(result.optimized);
  EXPECT_EQ(result.rounds_run, 4);
  EXPECT_LT(translation_error_m(result.T_cw, truth), 0.01);
  EXPECT_LT(rotation_error_deg(result.T_cw, truth), 0.1);

  int outliers = 0, outliers_flagged = 0, inliers = 0, inliers_kept = 0;
  for (std::size_t i = 0; i < frame.observations.size(); ++i) {
    if (frame.is_outlier[i]) {
      ++outliers;
      outliers_flagged += result.inlier[i] ? 0 : 1;
    } else {
      ++inliers;
      inliers_kept += result.inlier[i] ? 1 : 0;
    }
  }
  ASSERT_GT(outliers, 15);
  EXPECT_GE(outliers_flagged, 0.95 * outliers)
      << outliers_flagged << " of " << outliers << " outliers flagged";
  EXPECT_GE(inliers_kept, 0.95 * inliers) << inliers_kept << " of " << inliers << " inliers kept";
  EXPECT_EQ(result.num_inliers,
            static_cast<int>(std::count(result.inlier.begin(), result.inlier.end(), true)));
}

TEST(OptimPoseOnly, SameInputGivesBitIdenticalOutput) {
  const StereoCamera cam = test_camera();
  const Frame frame = synthetic_frame(cam, true_pose(), 200, 0.15, 8);
  const SE3 initial = perturbed(true_pose(), 0.10, 3.0);
  const PoseOptimizationResult a = optimize_pose(cam, initial, frame.observations);
  const PoseOptimizationResult b = optimize_pose(cam, initial, frame.observations);
  EXPECT_EQ(std::memcmp(a.T_cw.matrix().data(), b.T_cw.matrix().data(), sizeof(double) * 16), 0);
  EXPECT_EQ(a.inlier, b.inlier);
  EXPECT_EQ(a.num_inliers, b.num_inliers);
}

TEST(OptimPoseOnly, PointsBehindTheCameraAreOutliers) {
  const StereoCamera cam = test_camera();
  const SE3 truth = true_pose();
  Frame frame = synthetic_frame(cam, truth, 60, 0.0, 9);
  // Mirror three points through the camera centre: same pixel ray, negative depth.
  const SE3 T_wc = truth.inverse();
  for (int i = 0; i < 3; ++i) {
    PoseObservation& o = frame.observations[i];
    o.point_world = T_wc * (-(truth * o.point_world));
  }
  const PoseOptimizationResult result = optimize_pose(cam, perturbed(truth, 0.05, 1.0), frame.observations);
  for (int i = 0; i < 3; ++i) EXPECT_FALSE(result.inlier[i]) << "observation " << i;
  EXPECT_LT(translation_error_m(result.T_cw, truth), 0.01);
}

TEST(OptimPoseOnly, TooFewObservationsLeavesThePoseAlone) {
  const StereoCamera cam = test_camera();
  const Frame frame = synthetic_frame(cam, true_pose(), 2, 0.0, 10);
  const SE3 initial = perturbed(true_pose(), 0.1, 3.0);
  const PoseOptimizationResult result = optimize_pose(cam, initial, frame.observations);
  EXPECT_FALSE(result.optimized);
  EXPECT_EQ(std::memcmp(result.T_cw.matrix().data(), initial.matrix().data(), sizeof(double) * 16), 0);
}

TEST(OptimPoseOnly, RejectsNonPositiveSigma) {
  const StereoCamera cam = test_camera();
  Frame frame = synthetic_frame(cam, true_pose(), 10, 0.0, 11);
  frame.observations[4].sigma2 = 0.0;
  EXPECT_THROW(optimize_pose(cam, true_pose(), frame.observations), std::invalid_argument);
}

}  // namespace
}  // namespace porta::slam::optim

#endif  // PORTA_OPTIM_BUILT
