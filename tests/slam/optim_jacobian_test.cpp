// The optimisation's calculus: the SE(3) manifold (Plus/Minus, their Jacobians, exp/log) and the
// analytic Jacobians of the four reprojection costs against central differences, both with respect
// to the 7 ambient pose parameters and through the manifold (J_ambient * PlusJacobian equals the
// derivative of residual(Plus(x, delta)) at delta = 0), at many random poses and points.
#if PORTA_OPTIM_BUILT

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "porta/slam/optim/chi2.hpp"
#include "porta/slam/optim/reprojection_costs.hpp"
#include "porta/slam/optim/se3_manifold.hpp"
#include "random_draws.hpp"

namespace porta::slam::optim {
namespace {

using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;
using Vector6d = Eigen::Matrix<double, 6, 1>;

StereoCamera test_camera() { return StereoCamera{752, 480, 458.6, 457.3, 367.2, 248.4, 0.11}; }

SE3 random_pose(std::mt19937& rng, double max_angle) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vector3d axis = test::draw_xyz(u, rng);
  axis.normalize();
  const double angle = max_angle * std::abs(u(rng));
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
  T.translation() = test::draw_xyz(u, rng) * 2.0;
  return T;
}

// A world point in front of camera T_cw, at depth 1..20 m, projecting near the image.
Vector3d random_point_in_front(std::mt19937& rng, const SE3& T_cw) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_real_distribution<double> depth(1.0, 20.0);
  const double z = depth(rng);
  const double y = 0.4 * z * u(rng);  // y first: see random_draws.hpp
  const double x = 0.6 * z * u(rng);
  const Vector3d p_c(x, y, z);
  return T_cw.inverse() * p_c;
}

// Central difference of f: R^n -> R^m at x.
MatrixXd numeric_jacobian(const std::function<VectorXd(const VectorXd&)>& f, const VectorXd& x, double h) {
  const VectorXd f0 = f(x);
  MatrixXd J(f0.size(), x.size());
  for (int i = 0; i < x.size(); ++i) {
    VectorXd xp = x;
    VectorXd xm = x;
    xp[i] += h;
    xm[i] -= h;
    J.col(i) = (f(xp) - f(xm)) / (2.0 * h);
  }
  return J;
}

// ||A - B|| <= tol * max(1, ||B||) (Frobenius), printing both on failure.
void expect_close(const MatrixXd& analytic, const MatrixXd& numeric, double tol, const char* what) {
  ASSERT_EQ(analytic.rows(), numeric.rows());
  ASSERT_EQ(analytic.cols(), numeric.cols());
  const double err = (analytic - numeric).norm();
  EXPECT_LE(err, tol * std::max(1.0, numeric.norm())) << what << "\nanalytic:\n"
                                                      << analytic << "\nnumeric:\n"
                                                      << numeric;
}

VectorXd to_vector(const double* p, int n) { return Eigen::Map<const VectorXd>(p, n); }

// ---- Manifold -------------------------------------------------------------------------------------

TEST(OptimSe3Manifold, ParamsRoundTripAndLayout) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T = random_pose(rng, 3.0);
    const PoseParams p = pose_to_params(T);
    const Eigen::Quaterniond q(T.linear());
    EXPECT_NEAR(std::abs(q.coeffs().dot(Eigen::Map<const Eigen::Vector4d>(p.data()))), 1.0, 1e-12);
    EXPECT_GE(p[3], 0.0);  // qw >= 0
    EXPECT_EQ(Vector3d(p[4], p[5], p[6]), T.translation());
    EXPECT_LT((params_to_pose(p.data()).matrix() - T.matrix()).norm(), 1e-12);
  }
}

TEST(OptimSe3Manifold, ExpLogRoundTripIncludingSmallAndLargeAngles) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double angle : {0.0, 1e-12, 1e-9, 1e-5, 0.0099, 0.0101, 0.3, 1.5, 3.0, 3.1}) {
    Vector3d axis = test::draw_xyz(u, rng);
    axis.normalize();
    Vector6d delta;
    delta << angle * axis, test::draw_xyz(u, rng);
    const SE3 T = se3_exp(delta);
    EXPECT_NEAR(rotation_angle_rad(T.linear()), angle, 1e-12);
    const Vector6d back = se3_log(T);
    EXPECT_LT((back - delta).norm(), 1e-9 * std::max(1.0, delta.norm())) << "angle " << angle;
  }
}

TEST(OptimSe3Manifold, PlusIsLeftMultiplicationByExp) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  Se3Manifold manifold;
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T = random_pose(rng, 3.0);
    const PoseParams x = pose_to_params(T);
    Vector6d delta;
    for (int i = 0; i < 6; ++i) delta[i] = u(rng);
    PoseParams y{};
    ASSERT_TRUE(manifold.Plus(x.data(), delta.data(), y.data()));
    const SE3 expected = se3_exp(delta) * T;
    EXPECT_LT((params_to_pose(y.data()).matrix() - expected.matrix()).norm(), 1e-12);
    EXPECT_NEAR(Eigen::Map<const Eigen::Vector4d>(y.data()).norm(), 1.0, 1e-15);
  }
}

TEST(OptimSe3Manifold, PlusMinusRoundTrip) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Se3Manifold manifold;
  for (int trial = 0; trial < 50; ++trial) {
    const PoseParams x = pose_to_params(random_pose(rng, 3.0));
    Vector6d delta;
    for (int i = 0; i < 6; ++i) delta[i] = u(rng);  // rotation up to ~1.7 rad
    PoseParams y{};
    ASSERT_TRUE(manifold.Plus(x.data(), delta.data(), y.data()));
    Vector6d back;
    ASSERT_TRUE(manifold.Minus(y.data(), x.data(), back.data()));
    EXPECT_LT((back - delta).norm(), 1e-10) << "Minus(Plus(x, d), x) != d";

    const PoseParams z = pose_to_params(random_pose(rng, 3.0));
    Vector6d z_minus_x;
    ASSERT_TRUE(manifold.Minus(z.data(), x.data(), z_minus_x.data()));
    PoseParams z_again{};
    ASSERT_TRUE(manifold.Plus(x.data(), z_minus_x.data(), z_again.data()));
    EXPECT_LT((params_to_pose(z_again.data()).matrix() - params_to_pose(z.data()).matrix()).norm(), 1e-10)
        << "Plus(x, Minus(z, x)) != z";
  }
}

TEST(OptimSe3Manifold, PlusAndMinusJacobiansMatchNumericAndInvertEachOther) {
  std::mt19937 rng(5);
  Se3Manifold manifold;
  for (int trial = 0; trial < 20; ++trial) {
    const PoseParams x = pose_to_params(random_pose(rng, 3.0));
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_jacobian;
    Eigen::Matrix<double, 6, 7, Eigen::RowMajor> minus_jacobian;
    ASSERT_TRUE(manifold.PlusJacobian(x.data(), plus_jacobian.data()));
    ASSERT_TRUE(manifold.MinusJacobian(x.data(), minus_jacobian.data()));

    const auto plus_of_delta = [&](const VectorXd& d) {
      PoseParams y{};
      manifold.Plus(x.data(), d.data(), y.data());
      return to_vector(y.data(), 7);
    };
    expect_close(plus_jacobian, numeric_jacobian(plus_of_delta, VectorXd::Zero(6), 1e-6), 1e-8,
                 "PlusJacobian");

    const auto minus_of_y = [&](const VectorXd& y) {
      Vector6d d;
      manifold.Minus(y.data(), x.data(), d.data());
      return VectorXd(d);
    };
    expect_close(minus_jacobian, numeric_jacobian(minus_of_y, to_vector(x.data(), 7), 1e-6), 1e-8,
                 "MinusJacobian");
    expect_close(minus_jacobian * plus_jacobian, MatrixXd::Identity(6, 6), 1e-12, "MinusJ * PlusJ");
  }
}

// ---- Reprojection costs ---------------------------------------------------------------------------

// Checks one cost at pose x (and point X when it is a parameter): ambient Jacobians against central
// differences on the raw parameters, and the pose Jacobian chained with PlusJacobian against the
// derivative of residual(Plus(x, delta)) at delta = 0.
void check_cost(const ceres::CostFunction& cost, const PoseParams& x, const Vector3d* point) {
  const int m = cost.num_residuals();
  const bool has_point = point != nullptr;
  Vector3d X = has_point ? *point : Vector3d::Zero();

  const auto residual_at = [&](const double* pose, const double* pt) {
    const double* params[] = {pose, pt};
    VectorXd r(m);
    EXPECT_TRUE(cost.Evaluate(params, r.data(), nullptr));
    return r;
  };

  Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor> J_pose(m, 7);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> J_point(m, 3);
  double* jacobians[] = {J_pose.data(), J_point.data()};
  const double* params[] = {x.data(), X.data()};
  VectorXd r(m);
  ASSERT_TRUE(cost.Evaluate(params, r.data(), jacobians));
  EXPECT_LT((r - residual_at(x.data(), X.data())).norm(), 1e-15);

  const MatrixXd numeric_pose = numeric_jacobian(
      [&](const VectorXd& p) { return residual_at(p.data(), X.data()); }, to_vector(x.data(), 7), 1e-6);
  expect_close(J_pose, numeric_pose, 1e-6, "pose Jacobian (ambient)");

  Se3Manifold manifold;
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_jacobian;
  ASSERT_TRUE(manifold.PlusJacobian(x.data(), plus_jacobian.data()));
  const MatrixXd numeric_tangent = numeric_jacobian(
      [&](const VectorXd& d) {
        PoseParams y{};
        manifold.Plus(x.data(), d.data(), y.data());
        return residual_at(y.data(), X.data());
      },
      VectorXd::Zero(6), 1e-6);
  expect_close(J_pose * plus_jacobian, numeric_tangent, 1e-6, "pose Jacobian * PlusJacobian (tangent)");

  if (has_point) {
    const MatrixXd numeric_point =
        numeric_jacobian([&](const VectorXd& p) { return residual_at(x.data(), p.data()); }, X, 1e-6);
    expect_close(J_point, numeric_point, 1e-6, "point Jacobian");
  }
}

struct Sample {
  SE3 T_cw;
  Vector3d point;
  Vector3d prediction;  // u_l, v, u_r
};

std::vector<Sample> random_samples(int count, unsigned seed) {
  std::mt19937 rng(seed);
  const StereoCamera cam = test_camera();
  std::vector<Sample> samples;
  for (int i = 0; i < count; ++i) {
    Sample s;
    s.T_cw = random_pose(rng, 3.0);
    s.point = random_point_in_front(rng, s.T_cw);
    const Vector3d p = s.T_cw * s.point;
    const double u = cam.fx * p.x() / p.z() + cam.cx;
    s.prediction = Vector3d(u, cam.fy * p.y() / p.z() + cam.cy, u - cam.bf() / p.z());
    samples.push_back(s);
  }
  return samples;
}

TEST(OptimJacobians, StereoReprojectionMatchesNumericOnManifold) {
  const ProjectionModel model = ProjectionModel::from(test_camera());
  for (const Sample& s : random_samples(25, 10)) {
    // Observation a few pixels off the prediction, weighted as level 3 of a 1.2 pyramid.
    const StereoMeasurement obs{s.prediction.x() + 1.5, s.prediction.y() - 2.0, s.prediction.z() + 0.7};
    const StereoReprojectionCost cost(model, obs, 1.0 / std::sqrt(level_sigma2(3, 1.2)));
    check_cost(cost, pose_to_params(s.T_cw), &s.point);
  }
}

TEST(OptimJacobians, MonoReprojectionMatchesNumericOnManifold) {
  const ProjectionModel model = ProjectionModel::from(test_camera());
  for (const Sample& s : random_samples(25, 11)) {
    const MonoReprojectionCost cost(model, s.prediction.x() - 3.0, s.prediction.y() + 1.0, 1.0);
    check_cost(cost, pose_to_params(s.T_cw), &s.point);
  }
}

TEST(OptimJacobians, PoseOnlyCostsMatchNumericOnManifold) {
  const ProjectionModel model = ProjectionModel::from(test_camera());
  for (const Sample& s : random_samples(25, 12)) {
    const StereoPoseOnlyCost stereo(
        model, StereoMeasurement{s.prediction.x(), s.prediction.y(), s.prediction.z()}, 0.5, s.point);
    check_cost(stereo, pose_to_params(s.T_cw), nullptr);
    const MonoPoseOnlyCost mono(model, s.prediction.x() + 2.0, s.prediction.y(), 2.0, s.point);
    check_cost(mono, pose_to_params(s.T_cw), nullptr);
  }
}

TEST(OptimJacobians, ResidualIsWhitenedObservationMinusPrediction) {
  const ProjectionModel model = ProjectionModel::from(test_camera());
  const Sample s = random_samples(1, 13).front();
  const double sigma = 1.44;
  const StereoReprojectionCost cost(
      model, StereoMeasurement{s.prediction.x() + 1.0, s.prediction.y() - 2.0, s.prediction.z() + 3.0},
      1.0 / sigma);
  const PoseParams x = pose_to_params(s.T_cw);
  const double* params[] = {x.data(), s.point.data()};
  Vector3d r;
  ASSERT_TRUE(cost.Evaluate(params, r.data(), nullptr));
  EXPECT_LT((r - Vector3d(1.0, -2.0, 3.0) / sigma).norm(), 1e-9);
}

TEST(OptimJacobians, CeresGradientCheckerAgreesThroughTheManifold) {
  const ProjectionModel model = ProjectionModel::from(test_camera());
  Se3Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds = {&manifold, nullptr};
  for (const Sample& s : random_samples(10, 14)) {
    const StereoReprojectionCost cost(
        model, StereoMeasurement{s.prediction.x() + 1.0, s.prediction.y(), s.prediction.z() - 1.0}, 1.0);
    const ceres::NumericDiffOptions numeric_options;
    ceres::GradientChecker checker(&cost, &manifolds, numeric_options);
    ceres::GradientChecker::ProbeResults results;
    const PoseParams x = pose_to_params(s.T_cw);
    const double* params[] = {x.data(), s.point.data()};
    EXPECT_TRUE(checker.Probe(params, 1e-6, &results)) << results.error_log;
  }
}

}  // namespace
}  // namespace porta::slam::optim

#endif  // PORTA_OPTIM_BUILT
