// Trajectory evaluation with known answers (slam/eval, evaluation.hpp): each test builds an estimate
// from a ground truth by a transformation whose effect on ATE / RPE / the KITTI metric is known in
// closed form.
#if PORTA_EVAL_BUILT
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "porta/slam/evaluation.hpp"

namespace porta::slam {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = 180.0 / kPi;

SE3 make_pose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& position) {
  SE3 pose = SE3::Identity();
  pose.linear() = rotation;
  pose.translation() = position;
  return pose;
}

Eigen::Matrix3d rot(double angle_rad, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
}

// A closed 3-D loop (a wobbly ellipse) with turning orientation, 10 Hz.
Trajectory loop_trajectory(std::size_t n = 200) {
  Trajectory t;
  for (std::size_t k = 0; k < n; ++k) {
    const double a = 2.0 * kPi * static_cast<double>(k) / static_cast<double>(n);
    const Eigen::Vector3d p(20.0 * std::cos(a), 1.5 * std::sin(3.0 * a), 12.0 * std::sin(a));
    const Eigen::Matrix3d r =
        rot(a, Eigen::Vector3d::UnitY()) * rot(0.1 * std::sin(5.0 * a), Eigen::Vector3d::UnitX());
    t.poses.push_back({0.1 * static_cast<double>(k), make_pose(r, p)});
  }
  return t;
}

// Straight along +z (a KITTI camera driving forward), `step_m` per frame, times every 0.1 s.
Trajectory straight_trajectory(std::size_t n, double step_m) {
  Trajectory t;
  for (std::size_t k = 0; k < n; ++k)
    t.poses.push_back(
        {0.1 * static_cast<double>(k),
         make_pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, step_m * static_cast<double>(k)))});
  return t;
}

// est_0 = gt_0, est_k = est_{k-1} * (inv(gt_{k-1}) * gt_k) * drift: every relative motion is followed by
// the same small extra motion.
Trajectory with_per_step_drift(const Trajectory& gt, const SE3& drift) {
  Trajectory est = gt;
  for (std::size_t k = 1; k < gt.size(); ++k)
    est.poses[k].pose = est.poses[k - 1].pose * (gt.poses[k - 1].pose.inverse() * gt.poses[k].pose) * drift;
  return est;
}

// Every relative translation multiplied by `factor` (rotations kept).
Trajectory with_scaled_steps(const Trajectory& gt, double factor) {
  Trajectory est = gt;
  for (std::size_t k = 1; k < gt.size(); ++k) {
    SE3 step = gt.poses[k - 1].pose.inverse() * gt.poses[k].pose;
    step.translation() *= factor;
    est.poses[k].pose = est.poses[k - 1].pose * step;
  }
  return est;
}

EvaluationOptions with_alignment(AlignmentMethod method) {
  EvaluationOptions o;
  o.alignment = method;
  return o;
}

// ---- Statistics ------------------------------------------------------------------------------------

TEST(EvalStats, KnownListGivesItsStatistics) {
  const ErrorStats s = error_stats({3.0, 1.0, 4.0, 1.0, 5.0, 9.0});
  EXPECT_EQ(s.count, 6u);
  EXPECT_DOUBLE_EQ(s.mean, 23.0 / 6.0);
  EXPECT_DOUBLE_EQ(s.median, 3.5);  // even count: mean of the two middle values
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 9.0);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(133.0 / 6.0));
  EXPECT_NEAR(s.std, std::sqrt(133.0 / 6.0 - (23.0 / 6.0) * (23.0 / 6.0)), 1e-12);
  EXPECT_EQ(error_stats({}).count, 0u);
  EXPECT_EQ(error_stats({2.0, 7.0, 4.0}).median, 4.0);
}

// ---- Alignment -------------------------------------------------------------------------------------

TEST(EvalAlignment, RecoversAKnownSimilarity) {
  std::vector<Eigen::Vector3d> gt, est;
  const Eigen::Matrix3d r = rot(0.7, Eigen::Vector3d(1, 2, 3));
  const Eigen::Vector3d t(4, -5, 6);
  const double s = 0.4;
  for (const StampedPose& p : loop_trajectory(50).poses) {
    gt.push_back(p.pose.translation());
    est.push_back(r * p.pose.translation() + t);  // est = r gt + t  ->  gt = r^T (est - t)
    est.back() /= s;                              // ... with the estimate's scale off by 1/s
  }
  const Alignment a = align_points(gt, est, AlignmentMethod::sim3);
  EXPECT_NEAR(a.scale, s, 1e-12);
  EXPECT_TRUE(a.rotation.isApprox(r.transpose(), 1e-12));
  EXPECT_NEAR(a.rotation.determinant(), 1.0, 1e-12);
  for (std::size_t k = 0; k < gt.size(); ++k) EXPECT_LT((a.apply(est[k]) - gt[k]).norm(), 1e-9);
  const Alignment none = align_points(gt, est, AlignmentMethod::none);
  EXPECT_TRUE(none.rotation.isIdentity());
  EXPECT_EQ(none.scale, 1.0);
}

TEST(EvalAlignment, MirroredPointsStillGiveAProperRotation) {
  std::vector<Eigen::Vector3d> gt, est;
  for (const StampedPose& p : loop_trajectory(60).poses) {
    gt.push_back(p.pose.translation());
    est.push_back(
        Eigen::Vector3d(-p.pose.translation().x(), p.pose.translation().y(), p.pose.translation().z()));
  }
  EXPECT_NEAR(align_points(gt, est, AlignmentMethod::se3).rotation.determinant(), 1.0, 1e-12);
}

// ---- ATE -------------------------------------------------------------------------------------------

TEST(EvalAte, IdentityGivesZeroErrors) {
  const Trajectory gt = loop_trajectory();
  const EvaluationResult r = evaluate(gt, gt);
  EXPECT_EQ(r.association.matched(), gt.size());
  EXPECT_LT(r.ate.translation_m.max, 1e-9);
  EXPECT_LT(r.ate.rotation_deg.max, 1e-6);
  EXPECT_LT(r.rpe.translation_m.max, 1e-9);
  EXPECT_LT(r.rpe.rotation_deg.max, 1e-6);
  EXPECT_TRUE(r.alignment.rotation.isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_LT(r.alignment.translation.norm(), 1e-9);
}

TEST(EvalAte, RigidTransformVanishesAfterSe3AlignmentOnly) {
  const Trajectory gt = loop_trajectory();
  const SE3 other_world = make_pose(rot(1.1, Eigen::Vector3d(0.3, -1, 0.5)), Eigen::Vector3d(7, -3, 2));
  Trajectory est = gt;
  for (StampedPose& p : est.poses) p.pose = other_world * p.pose;  // the same motion in another world frame

  const EvaluationResult se3 = evaluate(gt, est);
  EXPECT_LT(se3.ate.translation_m.rmse, 1e-9);
  EXPECT_LT(se3.ate.rotation_deg.max, 1e-6);
  EXPECT_TRUE(se3.alignment.rotation.isApprox(other_world.linear().transpose(), 1e-9));
  EXPECT_DOUBLE_EQ(se3.alignment.scale, 1.0);
  EXPECT_LT(se3.rpe.translation_m.max, 1e-9);  // RPE needs no alignment

  const EvaluationResult none = evaluate(gt, est, with_alignment(AlignmentMethod::none));
  EXPECT_GT(none.ate.translation_m.rmse, 1.0);
  double sum_sq = 0.0;  // with no alignment, the ATE is the plain distance of the two positions
  for (std::size_t k = 0; k < gt.size(); ++k)
    sum_sq += (gt.poses[k].pose.translation() - est.poses[k].pose.translation()).squaredNorm();
  EXPECT_NEAR(none.ate.translation_m.rmse, std::sqrt(sum_sq / static_cast<double>(gt.size())), 1e-9);
  EXPECT_LT(none.rpe.translation_m.max, 1e-9);
}

TEST(EvalAte, KnownScaleVanishesOnlyWithSim3AndIsRecovered) {
  const Trajectory gt = loop_trajectory();
  const SE3 other_world = make_pose(rot(-0.4, Eigen::Vector3d(1, 1, 0)), Eigen::Vector3d(1, 2, 3));
  Trajectory est = gt;
  for (StampedPose& p : est.poses) {
    p.pose = other_world * p.pose;
    p.pose.translation() *= 2.5;  // a monocular estimate: the right shape at 2.5 times the size
  }
  const EvaluationResult se3 = evaluate(gt, est);
  EXPECT_GT(se3.ate.translation_m.rmse, 1.0);
  EXPECT_DOUBLE_EQ(se3.alignment.scale, 1.0);

  const EvaluationResult sim3 = evaluate(gt, est, with_alignment(AlignmentMethod::sim3));
  EXPECT_LT(sim3.ate.translation_m.rmse, 1e-9);
  EXPECT_NEAR(sim3.alignment.scale, 1.0 / 2.5, 1e-12);
  // The Sim(3) scale also applies to the relative motions of the RPE and KITTI metric.
  EXPECT_LT(sim3.rpe.translation_m.max, 1e-9);
}

// Offsets of norm d, alternating +d/-d along z on a loop whose positions are uncorrelated with that
// sign: the best alignment is the identity, so the ATE is d everywhere, with or without alignment.
TEST(EvalAte, ZeroMeanUncorrelatedOffsetsGiveTheirRmse) {
  const Trajectory gt = loop_trajectory(200);
  const double d = 0.25;
  Trajectory est = gt;
  for (std::size_t k = 0; k < est.size(); ++k) est.poses[k].pose.translation().z() += (k % 2 == 0 ? d : -d);

  for (const AlignmentMethod method : {AlignmentMethod::se3, AlignmentMethod::none}) {
    const EvaluationResult r = evaluate(gt, est, with_alignment(method));
    EXPECT_NEAR(r.ate.translation_m.rmse, d, 1e-9) << to_string(method);
    EXPECT_NEAR(r.ate.translation_m.mean, d, 1e-9);
    EXPECT_NEAR(r.ate.translation_m.median, d, 1e-9);
    EXPECT_NEAR(r.ate.translation_m.std, 0.0, 1e-9);
    EXPECT_NEAR(r.ate.translation_m.min, d, 1e-9);
    EXPECT_NEAR(r.ate.translation_m.max, d, 1e-9);
    EXPECT_LT(r.alignment.translation.norm(), 1e-9);
    // Consecutive offsets differ by 2d: the 1-frame RPE sees exactly that.
    EXPECT_NEAR(r.rpe.translation_m.rmse, 2.0 * d, 1e-9);
  }
}

TEST(EvalAte, TwoOffsetSizesGiveTheExpectedStatistics) {
  const Trajectory gt = loop_trajectory(200);
  Trajectory est = gt;
  for (std::size_t k = 0; k < est.size(); ++k)
    est.poses[k].pose.translation().y() += (k % 2 == 0 ? 0.1 : 0.3);
  const EvaluationResult r = evaluate(gt, est, with_alignment(AlignmentMethod::none));
  EXPECT_NEAR(r.ate.translation_m.rmse, std::sqrt((0.01 + 0.09) / 2.0), 1e-12);
  EXPECT_NEAR(r.ate.translation_m.mean, 0.2, 1e-12);
  EXPECT_NEAR(r.ate.translation_m.median, 0.2, 1e-12);
  EXPECT_NEAR(r.ate.translation_m.std, 0.1, 1e-12);
  EXPECT_NEAR(r.ate.translation_m.min, 0.1, 1e-12);
  EXPECT_NEAR(r.ate.translation_m.max, 0.3, 1e-12);
  ASSERT_EQ(r.ate.translation_errors_m.size(), gt.size());
  EXPECT_NEAR(r.ate.translation_errors_m[1], 0.3, 1e-12);
}

// ---- RPE -------------------------------------------------------------------------------------------

TEST(EvalRpe, ConstantPerStepErrorIsMeasuredExactly) {
  const Trajectory gt = loop_trajectory();
  const SE3 drift = make_pose(rot(0.01, Eigen::Vector3d::UnitY()), Eigen::Vector3d(0.03, 0.0, 0.04));
  const EvaluationResult r = evaluate(gt, with_per_step_drift(gt, drift));
  EXPECT_EQ(r.rpe.delta, "1 frame");
  EXPECT_EQ(r.rpe.translation_m.count, gt.size() - 1);
  EXPECT_NEAR(r.rpe.translation_m.rmse, 0.05, 1e-9);
  EXPECT_NEAR(r.rpe.translation_m.mean, 0.05, 1e-9);
  EXPECT_NEAR(r.rpe.translation_m.median, 0.05, 1e-9);
  EXPECT_NEAR(r.rpe.translation_m.max, 0.05, 1e-9);
  EXPECT_NEAR(r.rpe.rotation_deg.rmse, 0.01 * kDeg, 1e-7);
  EXPECT_NEAR(r.rpe.rotation_deg.max, 0.01 * kDeg, 1e-7);
  EXPECT_GT(r.ate.translation_m.rmse, 0.1);  // the drift accumulates in the absolute error
}

TEST(EvalRpe, FrameDeltaPairsFramesThatFarApart) {
  const Trajectory gt = straight_trajectory(50, 1.0);
  EvaluationOptions o;
  o.rpe.delta_frames = 10;
  const EvaluationResult r = evaluate(gt, with_scaled_steps(gt, 1.02), o);
  EXPECT_EQ(r.rpe.delta, "10 frames");
  ASSERT_EQ(r.rpe.first.size(), 40u);
  EXPECT_EQ(r.rpe.second.front(), 10u);
  EXPECT_NEAR(r.rpe.translation_m.max, 0.2, 1e-9);  // 2 % of 10 m
  EXPECT_NEAR(r.rpe.translation_m.mean, 0.2, 1e-9);
}

TEST(EvalRpe, DistanceDeltaPairsPosesThatFarApartAlongTheGroundTruth) {
  const Trajectory gt = straight_trajectory(101, 0.5);  // 50 m
  EvaluationOptions o;
  o.rpe.delta_distance_m = 5.0;
  const EvaluationResult r = evaluate(gt, with_scaled_steps(gt, 1.01), o);
  EXPECT_EQ(r.rpe.delta, "5 m");
  ASSERT_EQ(r.rpe.first.size(), 91u);  // starts 0..90 reach 5 m (10 steps of 0.5 m)
  for (std::size_t k = 0; k < r.rpe.first.size(); ++k) EXPECT_EQ(r.rpe.second[k], r.rpe.first[k] + 10);
  EXPECT_NEAR(r.rpe.translation_m.rmse, 0.05, 1e-9);
  EXPECT_NEAR(r.rpe.rotation_deg.max, 0.0, 1e-9);
}

// ---- KITTI relative errors -----------------------------------------------------------------------

TEST(EvalKitti, ScaledStepsGiveOnePercentTranslationError) {
  const Trajectory gt = straight_trajectory(1001, 1.0);  // 1000 m
  const Trajectory est = with_scaled_steps(gt, 1.01);
  Trajectory gt_no_times = gt, est_no_times = est;
  gt_no_times.has_times = est_no_times.has_times = false;
  const EvaluationResult r = evaluate(gt_no_times, est_no_times);  // by index: KITTI on by default
  ASSERT_TRUE(r.association.by_index);
  ASSERT_TRUE(r.kitti.has_value());
  const KittiResult& k = *r.kitti;
  EXPECT_NEAR(k.translation_percent, 1.0, 1e-9);
  EXPECT_NEAR(k.rotation_deg_per_100m, 0.0, 1e-9);
  ASSERT_EQ(k.per_length.size(), 8u);
  for (const KittiLengthStats& s : k.per_length) {
    // Starts every 10 frames (10 m) whose end still lies on the 1000 m path.
    EXPECT_EQ(s.segments, static_cast<std::size_t>((1000.0 - s.length_m) / 10.0) + 1) << s.length_m;
    EXPECT_NEAR(s.translation_percent, 1.0, 1e-9);
  }
  EXPECT_EQ(k.per_length.front().length_m, 100.0);
  EXPECT_EQ(k.per_length.back().length_m, 800.0);
  EXPECT_TRUE(k.note.empty());
}

TEST(EvalKitti, ConstantYawRateDriftGivesItsDegreesPerMetre) {
  const Trajectory gt = straight_trajectory(901, 1.0);
  const double yaw_per_step = 0.0005;  // rad per 1 m step, about the camera's y (down) axis
  const Trajectory est = with_per_step_drift(
      gt, make_pose(rot(yaw_per_step, Eigen::Vector3d::UnitY()), Eigen::Vector3d::Zero()));
  std::vector<SE3> g, e;
  for (std::size_t k = 0; k < gt.size(); ++k) {
    g.push_back(gt.poses[k].pose);
    e.push_back(est.poses[k].pose);
  }
  const KittiResult k = compute_kitti(g, e);
  EXPECT_NEAR(k.rotation_deg_per_m, yaw_per_step * kDeg, 1e-9);
  EXPECT_NEAR(k.rotation_deg_per_100m, 100.0 * yaw_per_step * kDeg, 1e-7);
  for (const KittiLengthStats& s : k.per_length)
    EXPECT_NEAR(s.rotation_deg_per_100m, 100.0 * yaw_per_step * kDeg, 1e-7);
  EXPECT_GT(k.translation_percent, 0.0);  // the estimate curves away
}

TEST(EvalKitti, ShortPathHasNoSegmentsAndSaysSo) {
  const Trajectory gt = straight_trajectory(50, 1.0);
  EvaluationOptions o;
  o.kitti = KittiMetric::on;
  const EvaluationResult r = evaluate(gt, gt, o);
  ASSERT_TRUE(r.kitti.has_value());
  EXPECT_EQ(r.kitti->segments, 0u);
  EXPECT_TRUE(r.kitti->per_length.empty());
  EXPECT_NE(r.kitti->note.find("shorter than the shortest segment (100 m)"), std::string::npos)
      << r.kitti->note;
}

TEST(EvalKitti, OffByDefaultForTimedInputsAndOnRequest) {
  const Trajectory gt = straight_trajectory(300, 1.0);
  EXPECT_FALSE(evaluate(gt, gt).kitti.has_value());
  EvaluationOptions o;
  o.kitti = KittiMetric::on;
  EXPECT_TRUE(evaluate(gt, gt, o).kitti.has_value());
}

TEST(EvalKitti, RelativePoseErrorIsInverseGtMotionTimesEstimateMotion) {
  const SE3 gi = make_pose(rot(0.2, Eigen::Vector3d::UnitZ()), Eigen::Vector3d(1, 2, 3));
  const SE3 gj = make_pose(rot(0.5, Eigen::Vector3d::UnitZ()), Eigen::Vector3d(4, 2, 3));
  const SE3 error = relative_pose_error(gi, gj, gi, gj);
  EXPECT_TRUE(error.isApprox(SE3::Identity(), 1e-12));
  const SE3 ej = gj * make_pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.1, 0, 0));
  EXPECT_NEAR(relative_pose_error(gi, gj, gi, ej).translation().norm(), 0.1, 1e-12);
}

}  // namespace
}  // namespace porta::slam

#else
#include <gtest/gtest.h>
TEST(EvalNotBuilt, Skipped) { GTEST_SKIP() << "porta_eval is not built (it needs OpenCV)"; }
#endif
