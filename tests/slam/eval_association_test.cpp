// Pairing estimate poses with ground truth (slam/eval, associate()): by nearest time within a
// tolerance, one-to-one, with a clock offset, with missing poses on either side; by index when a
// trajectory has no times.
#if PORTA_EVAL_BUILT
#include <gtest/gtest.h>

#include <string>

#include "porta/slam/evaluation.hpp"

namespace porta::slam {
namespace {

Trajectory timed(const std::vector<double>& times_s) {
  Trajectory t;
  for (const double time : times_s) {
    SE3 pose = SE3::Identity();
    pose.translation() = Eigen::Vector3d(time, 0.5 * time * time, 0.0);
    t.poses.push_back({time, pose});
  }
  return t;
}

std::vector<double> regular_times(std::size_t n, double period_s, double start_s = 0.0) {
  std::vector<double> times;
  for (std::size_t k = 0; k < n; ++k) times.push_back(start_s + period_s * static_cast<double>(k));
  return times;
}

std::string error_of(const Trajectory& gt, const Trajectory& est, const AssociationOptions& options = {}) {
  try {
    associate(gt, est, options);
  } catch (const EvaluationError& e) {
    return e.what();
  }
  return "";
}

TEST(EvalAssociation, JitteredTimesGoToTheNearestGroundTruth) {
  const Trajectory gt = timed(regular_times(1000, 0.01));  // 100 Hz
  std::vector<double> est_times;
  for (std::size_t m = 0; m < 95; ++m)  // 10 Hz with +-3 ms of jitter
    est_times.push_back(0.1 * static_cast<double>(m) + (m % 3 == 0 ? 0.003 : m % 3 == 1 ? -0.003 : 0.0));
  const Association a = associate(gt, timed(est_times));
  EXPECT_FALSE(a.by_index);
  ASSERT_EQ(a.matched(), 95u);
  EXPECT_EQ(a.unmatched_estimates(), 0u);
  EXPECT_EQ(a.unmatched_ground_truth(), 1000u - 95u);
  for (std::size_t m = 0; m < a.matched(); ++m) {
    EXPECT_EQ(a.est_index[m], m);
    EXPECT_EQ(a.gt_index[m], 10 * m) << "estimate " << m;
  }
  EXPECT_NEAR(a.max_abs_time_diff_s, 0.003, 1e-9);
}

TEST(EvalAssociation, ClockOffsetIsAppliedToTheEstimate) {
  const Trajectory gt = timed(regular_times(200, 0.05, 1000.0));
  const Trajectory est = timed(regular_times(100, 0.1, 7.0));  // another clock, 993 s behind
  EXPECT_NE(error_of(gt, est).find("only 0 of the estimate's 100 poses"), std::string::npos)
      << error_of(gt, est);
  AssociationOptions o;
  o.time_offset_s = 993.0;
  const Association a = associate(gt, est, o);
  ASSERT_EQ(a.matched(), 100u);
  for (std::size_t m = 0; m < a.matched(); ++m) EXPECT_EQ(a.gt_index[m], 2 * m);
}

TEST(EvalAssociation, PosesWithoutPartnersStayUnmatched) {
  // Ground truth has a gap from 2 s to 3 s; the estimate loses tracking from 5 s to 6 s.
  std::vector<double> gt_times, est_times;
  for (const double t : regular_times(1000, 0.01))
    if (t < 2.0 - 1e-9 || t > 3.0 + 1e-9) gt_times.push_back(t);
  for (const double t : regular_times(100, 0.1))
    if (t < 5.0 - 1e-9 || t > 6.0 + 1e-9) est_times.push_back(t);
  const Association a = associate(timed(gt_times), timed(est_times));
  // Estimate poses at 2.1 .. 2.9 s have no ground truth within 20 ms; those at 2.0 and 3.0 pair with
  // the ground truth 10 ms away (1.99 and 3.01 s).
  EXPECT_EQ(a.est_count, 100u - 11u);
  EXPECT_EQ(a.matched(), 89u - 9u);
  EXPECT_EQ(a.unmatched_estimates(), 9u);
  EXPECT_NEAR(a.max_abs_time_diff_s, 0.01, 1e-9);
}

TEST(EvalAssociation, EachGroundTruthPoseIsUsedOnce) {
  const Trajectory gt = timed({0.0, 0.1, 0.2, 0.3, 0.4});
  // 0.09 and 0.095 both lie nearest to 0.1; the closer one (0.095) takes it, 0.09 has no other
  // ground truth within 20 ms and stays unmatched.
  const Association a = associate(gt, timed({0.09, 0.095, 0.2, 0.31}));
  ASSERT_EQ(a.matched(), 3u);
  EXPECT_EQ(a.est_index, (std::vector<std::size_t>{1, 2, 3}));
  EXPECT_EQ(a.gt_index, (std::vector<std::size_t>{1, 2, 3}));
}

TEST(EvalAssociation, ToleranceIsRespected) {
  const Trajectory gt = timed(regular_times(100, 0.1));
  const Trajectory est = timed(regular_times(50, 0.1, 0.03));  // 30 ms late
  EXPECT_FALSE(error_of(gt, est).empty());
  AssociationOptions o;
  o.max_time_diff_s = 0.035;
  EXPECT_EQ(associate(gt, est, o).matched(), 50u);
}

TEST(EvalAssociation, WithoutTimesPosesArePairedByIndex) {
  Trajectory gt = timed(regular_times(20, 0.1));
  Trajectory est = timed(regular_times(20, 0.5, 100.0));  // times that would never match
  est.has_times = false;
  const Association a = associate(gt, est);
  EXPECT_TRUE(a.by_index);
  ASSERT_EQ(a.matched(), 20u);
  EXPECT_EQ(a.gt_index[7], 7u);
  EXPECT_EQ(a.est_index[7], 7u);
}

TEST(EvalAssociation, ByIndexNeedsEqualCounts) {
  Trajectory gt = timed(regular_times(20, 0.1));
  Trajectory est = timed(regular_times(19, 0.1));
  gt.has_times = est.has_times = false;
  const std::string message = error_of(gt, est);
  EXPECT_NE(message.find("neither trajectory has timestamps"), std::string::npos) << message;
  EXPECT_NE(message.find("ground truth has 20 poses and the estimate 19"), std::string::npos) << message;
}

TEST(EvalAssociation, FewerThanThreePairsIsAnError) {
  const std::string message = error_of(timed({0.0, 1.0, 2.0, 3.0}), timed({0.0, 1.0, 5.0}));
  EXPECT_NE(message.find("only 2 of the estimate's 3 poses"), std::string::npos) << message;
  EXPECT_NE(message.find("at least 3"), std::string::npos) << message;
  EXPECT_NE(error_of(timed({}), timed({0.0})).find("ground truth has no poses"), std::string::npos);
}

}  // namespace
}  // namespace porta::slam
#endif
