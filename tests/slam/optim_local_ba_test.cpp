// Local bundle adjustment (ORB-SLAM2's LocalBundleAdjustment) on a synthetic scene: 6 keyframes along
// a path (the first 2 fixed), 300 points, stereo and mono observations with 1 px noise and 3% gross
// outliers, noisy initial poses and points. BA must bring the reprojection RMSE down to the noise,
// the free poses to within a centimetre, report the outliers, leave fixed poses bit-identical,
// repeat bit-for-bit, and honour the stop flag.
#if PORTA_OPTIM_BUILT

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "cpu/thread_pool.hpp"
#include "porta/slam/optim/local_bundle_adjustment.hpp"
#include "random_draws.hpp"

namespace porta::slam::optim {
namespace {

using Eigen::Vector3d;

StereoCamera test_camera() { return StereoCamera{640, 480, 400.0, 400.0, 320.0, 240.0, 0.2}; }

struct Scene {
  std::vector<SE3> true_T_cw;
  std::vector<Vector3d> true_points;
  std::vector<BaKeyframe> keyframes;  // initial estimates
  std::vector<Vector3d> points;       // initial estimates
  std::vector<BaObservation> observations;
  std::vector<bool> is_outlier;  // injected
};

bool same_bits(const SE3& a, const SE3& b) {
  return std::memcmp(a.matrix().data(), b.matrix().data(), sizeof(double) * 16) == 0;
}

double centre_error_m(const SE3& a, const SE3& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();
}
double rotation_error_deg(const SE3& a, const SE3& b) {
  return rotation_angle_rad(a.linear() * b.linear().transpose()) * 180.0 / std::numbers::pi;
}

Scene synthetic_scene(int num_fixed, unsigned seed, double noise_px = 1.0, double outlier_fraction = 0.03) {
  const StereoCamera cam = test_camera();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Scene s;
  // Keyframes every ~40 cm along a gentle curve, turning slowly, looking along +z.
  for (int k = 0; k < 6; ++k) {
    SE3 T_wc = SE3::Identity();
    T_wc.linear() = Eigen::AngleAxisd(0.04 * k, Vector3d::UnitY()).toRotationMatrix() *
                    Eigen::AngleAxisd(0.01 * k, Vector3d::UnitX()).toRotationMatrix();
    T_wc.translation() = Vector3d(0.4 * k, 0.05 * std::sin(k), 0.1 * k);
    s.true_T_cw.push_back(T_wc.inverse());
  }
  for (int i = 0; i < 300; ++i) {
    const Vector3d r = test::draw_xyz(uniform, rng);
    s.true_points.emplace_back(-2.0 + 6.0 * r.x(), -1.5 + 3.0 * r.y(), 2.5 + 5.0 * r.z());
  }
  for (int k = 0; k < 6; ++k) {
    SE3 T = s.true_T_cw[k];
    if (k >= num_fixed) {  // ~5 cm, ~1 degree off
      SE3 delta = SE3::Identity();
      const Vector3d axis = test::draw_xyz(gauss, rng).normalized();
      delta.linear() = Eigen::AngleAxisd(std::numbers::pi / 180.0, axis).toRotationMatrix();
      delta.translation() = 0.05 * test::draw_xyz(gauss, rng).normalized();
      T = delta * T;
    }
    s.keyframes.push_back({T, k < num_fixed});
  }
  for (const Vector3d& X : s.true_points) s.points.push_back(X + 0.05 * test::draw_xyz(gauss, rng));

  for (std::size_t k = 0; k < 6; ++k) {
    for (std::size_t i = 0; i < s.true_points.size(); ++i) {
      const Vector3d p = s.true_T_cw[k] * s.true_points[i];
      const double u = cam.fx * p.x() / p.z() + cam.cx;
      const double v = cam.fy * p.y() / p.z() + cam.cy;
      if (p.z() < 0.5 || u < 0.0 || u >= cam.width || v < 0.0 || v >= cam.height) continue;
      BaObservation o;
      o.keyframe = k;
      o.point = i;
      o.u_left = u + noise_px * gauss(rng);
      o.v = v + noise_px * gauss(rng);
      const bool stereo = uniform(rng) < 0.6;
      if (stereo) o.u_right = u - cam.bf() / p.z() + noise_px * gauss(rng);
      o.sigma2 = 1.0;
      const bool outlier = uniform(rng) < outlier_fraction;
      if (outlier) {
        const double angle = 2.0 * std::numbers::pi * uniform(rng);
        const double distance = 20.0 + 60.0 * uniform(rng);
        o.u_left += distance * std::cos(angle);
        o.v += distance * std::sin(angle);
        if (stereo) o.u_right += distance * std::cos(angle);
      }
      s.observations.push_back(o);
      s.is_outlier.push_back(outlier);
    }
  }
  return s;
}

// RMS pixel residual per coordinate over the observations flagged true in `use`.
double rmse_px(const Scene& s, const std::vector<SE3>& T_cw, const std::vector<Vector3d>& points,
               const std::vector<bool>& use) {
  const StereoCamera cam = test_camera();
  double sum = 0.0;
  int n = 0;
  for (std::size_t j = 0; j < s.observations.size(); ++j) {
    if (!use[j]) continue;
    const BaObservation& o = s.observations[j];
    const Vector3d p = T_cw[o.keyframe] * points[o.point];
    const double u = cam.fx * p.x() / p.z() + cam.cx;
    const double v = cam.fy * p.y() / p.z() + cam.cy;
    sum += (u - o.u_left) * (u - o.u_left) + (v - o.v) * (v - o.v);
    n += 2;
    if (o.is_stereo()) {
      const double ur = u - cam.bf() / p.z();
      sum += (ur - o.u_right) * (ur - o.u_right);
      ++n;
    }
  }
  return std::sqrt(sum / n);
}

std::vector<SE3> initial_poses(const Scene& s) {
  std::vector<SE3> T;
  for (const BaKeyframe& kf : s.keyframes) T.push_back(kf.T_cw);
  return T;
}

TEST(OptimLocalBa, ConvergesToNoiseLevelAndReportsOutliers) {
  const Scene s = synthetic_scene(2, 21);
  ASSERT_GT(s.observations.size(), 1200u);
  std::vector<bool> true_inliers(s.observations.size());
  for (std::size_t j = 0; j < true_inliers.size(); ++j) true_inliers[j] = !s.is_outlier[j];
  const double initial_rmse = rmse_px(s, initial_poses(s), s.points, true_inliers);

  const LocalBundleAdjustmentResult r =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations);

  EXPECT_GT(initial_rmse, 5.0);
  // The noise is 1 px; the chi2 cut trims its tails and the fit absorbs ~30% of the degrees of freedom.
  EXPECT_GT(r.final_rmse_px, 0.7);
  EXPECT_LT(r.final_rmse_px, 1.05);
  EXPECT_LT(rmse_px(s, r.T_cw, r.points, true_inliers), 1.1);
  EXPECT_LT(r.final_cost, r.initial_cost);
  EXPECT_GT(r.iterations, 0);
  EXPECT_LE(r.iterations, 15);
  EXPECT_GT(r.time_s, 0.0);
  EXPECT_FALSE(r.stopped);

  for (std::size_t k = 0; k < s.keyframes.size(); ++k) {
    if (s.keyframes[k].fixed) {
      EXPECT_TRUE(same_bits(r.T_cw[k], s.keyframes[k].T_cw)) << "fixed keyframe " << k << " moved";
    } else {
      EXPECT_LT(centre_error_m(r.T_cw[k], s.true_T_cw[k]), 0.01) << "keyframe " << k;
      EXPECT_LT(rotation_error_deg(r.T_cw[k], s.true_T_cw[k]), 0.1) << "keyframe " << k;
      EXPECT_GT(centre_error_m(s.keyframes[k].T_cw, s.true_T_cw[k]), 0.03) << "keyframe " << k;
    }
  }
  std::vector<double> point_errors;
  for (std::size_t i = 0; i < s.points.size(); ++i)
    point_errors.push_back((r.points[i] - s.true_points[i]).norm());
  std::nth_element(point_errors.begin(), point_errors.begin() + 150, point_errors.end());
  EXPECT_LT(point_errors[150], 0.05) << "median point error (m)";

  std::vector<bool> reported(s.observations.size(), false);
  for (std::size_t j : r.outlier_observations) reported[j] = true;
  EXPECT_TRUE(std::is_sorted(r.outlier_observations.begin(), r.outlier_observations.end()));
  int outliers = 0, caught = 0, inliers = 0, false_alarms = 0;
  for (std::size_t j = 0; j < s.observations.size(); ++j) {
    if (s.is_outlier[j]) {
      ++outliers;
      caught += reported[j] ? 1 : 0;
    } else {
      ++inliers;
      false_alarms += reported[j] ? 1 : 0;
    }
  }
  ASSERT_GT(outliers, 20);
  EXPECT_GE(caught, 0.95 * outliers) << caught << " of " << outliers << " injected outliers reported";
  EXPECT_LE(false_alarms, 0.08 * inliers) << false_alarms << " of " << inliers << " inliers reported";
}

// The solver converges: started from the noisy estimate it reaches the optimum it reaches from the
// ground truth (which is not the ground truth itself: 1 px noise leaves a few mm of pose error).
TEST(OptimLocalBa, ReachesTheSameOptimumAsFromGroundTruth) {
  const Scene s = synthetic_scene(2, 27);
  Scene from_truth = s;
  for (std::size_t k = 0; k < s.keyframes.size(); ++k) from_truth.keyframes[k].T_cw = s.true_T_cw[k];
  from_truth.points = s.true_points;
  const LocalBundleAdjustmentResult a =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations);
  const LocalBundleAdjustmentResult b = local_bundle_adjustment(test_camera(), from_truth.keyframes,
                                                                from_truth.points, from_truth.observations);
  for (std::size_t k = 2; k < s.keyframes.size(); ++k) {
    EXPECT_LT(centre_error_m(a.T_cw[k], b.T_cw[k]), 0.002) << "keyframe " << k;
  }
  EXPECT_NEAR(a.final_cost, b.final_cost, 0.01 * b.final_cost);
}

TEST(OptimLocalBa, NoiseFreeObservationsAreFitExactly) {
  const Scene s = synthetic_scene(2, 28, 0.0, 0.0);
  const LocalBundleAdjustmentResult r =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations);
  EXPECT_LT(r.final_rmse_px, 1e-6);
  EXPECT_TRUE(r.outlier_observations.empty());
  for (std::size_t k = 2; k < s.keyframes.size(); ++k)
    EXPECT_LT(centre_error_m(r.T_cw[k], s.true_T_cw[k]), 1e-6);
}

TEST(OptimLocalBa, SameInputGivesBitIdenticalOutput) {
  const Scene s = synthetic_scene(2, 22);
  const LocalBundleAdjustmentResult a =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations);
  const LocalBundleAdjustmentResult b =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations);
  for (std::size_t k = 0; k < a.T_cw.size(); ++k) EXPECT_TRUE(same_bits(a.T_cw[k], b.T_cw[k])) << k;
  ASSERT_EQ(a.points.size(), b.points.size());
  EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), sizeof(Vector3d) * a.points.size()), 0);
  EXPECT_EQ(a.outlier_observations, b.outlier_observations);
  EXPECT_EQ(a.final_cost, b.final_cost);
}

TEST(OptimLocalBa, StopFlagSetBeforehandSkipsOptimisationButStillChecksOutliers) {
  const Scene s = synthetic_scene(2, 23);
  std::atomic<bool> stop{true};
  LocalBundleAdjustmentOptions options;
  options.stop_flag = &stop;
  const LocalBundleAdjustmentResult r =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, options);
  EXPECT_TRUE(r.stopped);
  EXPECT_EQ(r.iterations, 0);
  for (std::size_t k = 0; k < s.keyframes.size(); ++k) EXPECT_TRUE(same_bits(r.T_cw[k], s.keyframes[k].T_cw));
  EXPECT_FALSE(r.outlier_observations.empty());  // the initial state is far off: many fail the test
}

TEST(OptimLocalBa, StopFlagClearedRunsToTheEnd) {
  const Scene s = synthetic_scene(2, 24);
  std::atomic<bool> stop{false};
  LocalBundleAdjustmentOptions options;
  options.stop_flag = &stop;
  const LocalBundleAdjustmentResult with_flag =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, options);
  const LocalBundleAdjustmentResult without =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations);
  EXPECT_FALSE(with_flag.stopped);
  EXPECT_EQ(with_flag.iterations, without.iterations);
  for (std::size_t k = 0; k < s.keyframes.size(); ++k)
    EXPECT_TRUE(same_bits(with_flag.T_cw[k], without.T_cw[k]));
}

// A looser function tolerance ends the stages sooner (fewer iterations), near the same optimum:
// its cost within 1 % of the tight run's (a stage stops once an iteration gains at most 1e-2 of
// the cost), on both the Schur solver and Ceres'. A tolerance outside (0, 1) is refused.
TEST(OptimLocalBa, LooserFunctionToleranceStopsSoonerNearTheSameOptimum) {
  const Scene s = synthetic_scene(2, 26);
  for (const BaSolver solver : {BaSolver::schur, BaSolver::ceres_dense_schur}) {
    LocalBundleAdjustmentOptions tight, loose;
    tight.solver = loose.solver = solver;
    loose.function_tolerance = 1e-2;
    const LocalBundleAdjustmentResult a =
        local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, tight);
    const LocalBundleAdjustmentResult b =
        local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, loose);
    EXPECT_LT(b.iterations, a.iterations) << static_cast<int>(solver);
    EXPECT_LT(b.final_cost, b.initial_cost);
    EXPECT_LT(b.final_cost, 1.01 * a.final_cost + 1e-9) << static_cast<int>(solver);
  }
  for (const double bad : {0.0, 1.0, -1e-3}) {
    LocalBundleAdjustmentOptions options;
    options.function_tolerance = bad;
    EXPECT_THROW(local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, options),
                 std::invalid_argument)
        << bad;
  }
}

TEST(OptimLocalBa, AllKeyframesFixedRefinesPointsOnly) {
  Scene s = synthetic_scene(6, 25);
  const LocalBundleAdjustmentResult r =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations);
  for (std::size_t k = 0; k < s.keyframes.size(); ++k) EXPECT_TRUE(same_bits(r.T_cw[k], s.keyframes[k].T_cw));
  EXPECT_LT(r.final_rmse_px, 1.1);
}

// Our Schur solver and Ceres' DENSE_SCHUR and SPARSE_SCHUR: from the same noisy start (3% gross
// outliers) all three end at the same optimum and report the same outliers. They stop by the
// function tolerance, not always at the same iteration (rounding), so the poses agree to tens of
// micrometres along the flattest directions, far below the 1 px noise's millimetres.
void expect_same_optimum(const Scene& s, const char* what) {
  LocalBundleAdjustmentResult by[3];
  const BaSolver solvers[3] = {BaSolver::schur, BaSolver::ceres_dense_schur, BaSolver::ceres_sparse_schur};
  for (int i = 0; i < 3; ++i) {
    LocalBundleAdjustmentOptions options;
    options.solver = solvers[i];
    by[i] = local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, options);
  }
  for (int i = 1; i < 3; ++i) {
    SCOPED_TRACE(std::string(what) + (i == 1 ? ": against ceres_dense_schur" : ": against ceres_sparse_schur"));
    EXPECT_NEAR(by[0].initial_cost, by[i].initial_cost, 1e-9 * by[i].initial_cost);
    EXPECT_NEAR(by[0].final_cost, by[i].final_cost, 1e-6 * by[i].final_cost);
    EXPECT_EQ(by[0].outlier_observations, by[i].outlier_observations);
    for (std::size_t k = 0; k < s.keyframes.size(); ++k) {
      EXPECT_LT(centre_error_m(by[0].T_cw[k], by[i].T_cw[k]), 1e-4) << "keyframe " << k;
      EXPECT_LT(rotation_error_deg(by[0].T_cw[k], by[i].T_cw[k]), 1e-3) << "keyframe " << k;
    }
    double worst = 0.0;
    for (std::size_t p = 0; p < s.points.size(); ++p) worst = std::max(worst, (by[0].points[p] - by[i].points[p]).norm());
    EXPECT_LT(worst, 1e-3) << "largest point difference (m)";
  }
  EXPECT_LT(by[0].final_rmse_px, 1.05);
}

TEST(OptimLocalBa, SchurSolverReachesTheOptimumCeresReaches) {
  expect_same_optimum(synthetic_scene(2, 31), "two fixed keyframes");
  expect_same_optimum(synthetic_scene(1, 32), "one fixed keyframe");
  expect_same_optimum(synthetic_scene(0, 33), "none fixed: the oldest is held (gauge)");
}

// Information far below a pixel's (sigma 30 000 px here; a distant point's block of the normal
// equations is as small): every point's 3x3 block has a determinant ~1e-14, under Eigen's absolute
// 1e-12 for an invertible matrix, though each is as well conditioned as at sigma 1 px. The solver
// must judge invertibility relative to the block's scale, as Ceres (which inverts by Cholesky) does,
// and reach Ceres' optimum; judged absolutely, every step would fail as singular.
TEST(OptimLocalBa, SchurSolverStepsWhenThePointsInformationIsTiny) {
  Scene s = synthetic_scene(2, 35, 1.0, 0.0);
  for (BaObservation& o : s.observations) o.sigma2 = 9e8;
  expect_same_optimum(s, "sigma 30 000 px");
}

// A point measured twice in one keyframe (two features on one point: rare in a map, allowed by the
// interface) puts two cross terms in one diagonal block of the reduced system.
TEST(OptimLocalBa, SchurSolverHandlesTwoObservationsOfAPointInOneKeyframe) {
  Scene s = synthetic_scene(2, 34);
  const std::size_t n = s.observations.size();
  for (std::size_t j = 0; j < n; j += 7) {
    BaObservation twice = s.observations[j];
    twice.u_left += 0.5;
    twice.v -= 0.5;
    s.observations.push_back(twice);
    s.is_outlier.push_back(s.is_outlier[j]);
  }
  expect_same_optimum(s, "duplicated observations");
}

void expect_same_bits(const LocalBundleAdjustmentResult& a, const LocalBundleAdjustmentResult& b) {
  ASSERT_EQ(a.T_cw.size(), b.T_cw.size());
  for (std::size_t k = 0; k < a.T_cw.size(); ++k) EXPECT_TRUE(same_bits(a.T_cw[k], b.T_cw[k])) << "keyframe " << k;
  ASSERT_EQ(a.points.size(), b.points.size());
  EXPECT_EQ(std::memcmp(a.points.data(), b.points.data(), sizeof(Vector3d) * a.points.size()), 0);
  EXPECT_EQ(a.outlier_observations, b.outlier_observations);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(std::memcmp(&a.final_cost, &b.final_cost, sizeof(double)), 0) << a.final_cost << " vs " << b.final_cost;
}

// The schur solver's loops split by point, by keyframe and by block of the reduced system, each
// summing in the order of the one-thread sweep: any split gives that sweep's bits. Checked with
// the indices run backwards on one thread, on a pool of 4 kept by the caller, and on the pool
// num_threads = 3 starts; the scene has two fixed keyframes and points measured twice in one
// keyframe (both cross terms in one diagonal block).
TEST(OptimLocalBa, SchurSolverGivesTheSameBitsOnAnyNumberOfThreads) {
  Scene s = synthetic_scene(2, 36);
  const std::size_t n = s.observations.size();
  for (std::size_t j = 0; j < n; j += 5) {
    BaObservation twice = s.observations[j];
    twice.u_left -= 0.4;
    s.observations.push_back(twice);
  }
  const LocalBundleAdjustmentResult one_sweep =
      local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations);
  ASSERT_GT(one_sweep.iterations, 3);

  LocalBundleAdjustmentOptions backwards;
  backwards.parallel_for = [](std::int64_t count, const std::function<void(std::int64_t)>& fn) {
    for (std::int64_t i = count - 1; i >= 0; --i) fn(i);
  };
  cpu::ThreadPool pool(4);
  LocalBundleAdjustmentOptions kept_pool;
  kept_pool.parallel_for = [&pool](std::int64_t count, const std::function<void(std::int64_t)>& fn) {
    pool.parallel_for(0, count, fn);
  };
  LocalBundleAdjustmentOptions own_pool;
  own_pool.num_threads = 3;
  for (const auto& [name, options] : {std::pair{"backwards", &backwards}, std::pair{"kept pool of 4", &kept_pool},
                                      std::pair{"num_threads 3", &own_pool}}) {
    SCOPED_TRACE(name);
    expect_same_bits(one_sweep, local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, *options));
  }
}

TEST(OptimLocalBa, RejectsAThreadCountOutOfRange) {
  const Scene s = synthetic_scene(2, 37);
  for (const int threads : {0, -2, 257}) {
    LocalBundleAdjustmentOptions options;
    options.num_threads = threads;
    try {
      (void)local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, options);
      ADD_FAILURE() << "num_threads " << threads << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("num_threads = " + std::to_string(threads)), std::string::npos)
          << e.what();
    }
  }
}

TEST(OptimLocalBa, StopFlagRaisedBetweenIterationsEndsTheAdjustmentThere) {
  const Scene s = synthetic_scene(2, 35);
  for (const BaSolver solver : {BaSolver::schur, BaSolver::ceres_dense_schur}) {
    std::atomic<bool> stop{false};
    int calls = 0;
    LocalBundleAdjustmentOptions options;
    options.solver = solver;
    options.stop_flag = &stop;
    options.between_iterations = [&] {
      if (++calls == 2) stop = true;
    };
    const LocalBundleAdjustmentResult r =
        local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations, options);
    EXPECT_TRUE(r.stopped);
    EXPECT_EQ(calls, 2);
    EXPECT_EQ(r.iterations, 2);
    EXPECT_LT(r.final_cost, r.initial_cost);  // two steps of the first stage were taken
  }
}

TEST(OptimLocalBa, RejectsObservationOfMissingKeyframeOrPoint) {
  Scene s = synthetic_scene(2, 26);
  s.observations[3].keyframe = 6;
  EXPECT_THROW(local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations),
               std::invalid_argument);
  s.observations[3].keyframe = 0;
  s.observations[5].point = 300;
  EXPECT_THROW(local_bundle_adjustment(test_camera(), s.keyframes, s.points, s.observations),
               std::invalid_argument);
}

}  // namespace
}  // namespace porta::slam::optim

#endif  // PORTA_OPTIM_BUILT
