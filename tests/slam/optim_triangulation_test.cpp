// Map point creation: linear two-view triangulation is exact on noise-free data; the checks reject
// low parallax, points behind a camera and observations that do not reproject; stereo
// back-projection puts a keypoint at depth bf / disparity and reprojects exactly.
#if PORTA_OPTIM_BUILT

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "porta/slam/optim/triangulation.hpp"

namespace porta::slam::optim {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

StereoCamera test_camera() { return StereoCamera{752, 480, 458.6, 457.3, 367.2, 248.4, 0.11}; }

SE3 camera_at(const Vector3d& centre, double yaw_rad) {  // T_cw of a camera at `centre`
  SE3 T_wc = SE3::Identity();
  T_wc.linear() = Eigen::AngleAxisd(yaw_rad, Vector3d::UnitY()).toRotationMatrix();
  T_wc.translation() = centre;
  return T_wc.inverse();
}

Vector2d project(const StereoCamera& cam, const SE3& T_cw, const Vector3d& X) {
  const Vector3d p = T_cw * X;
  return {cam.fx * p.x() / p.z() + cam.cx, cam.fy * p.y() / p.z() + cam.cy};
}

TEST(OptimTriangulation, LinearIsExactOnNoiseFreeData) {
  const StereoCamera cam = test_camera();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const SE3 T1 = camera_at(Vector3d(u(rng), u(rng), u(rng)), 0.3 * u(rng));
    const SE3 T2 = camera_at(Vector3d(u(rng), u(rng), u(rng)) + Vector3d(1.0, 0.0, 0.0), 0.3 * u(rng));
    const Vector3d X(2.0 * u(rng), u(rng), 6.0 + 3.0 * u(rng));
    const std::optional<Vector3d> linear =
        triangulate_linear_pixels(cam, T1, project(cam, T1, X), T2, project(cam, T2, X));
    ASSERT_TRUE(linear.has_value());
    EXPECT_LT((*linear - X).norm(), 1e-9 * X.norm());

    const std::optional<Vector3d> checked =
        triangulate_checked(cam, {T1, project(cam, T1, X), 1.0}, {T2, project(cam, T2, X), 1.0});
    ASSERT_TRUE(checked.has_value());
    EXPECT_LT((*checked - X).norm(), 1e-9 * X.norm());
  }
}

TEST(OptimTriangulation, RejectsLowParallax) {
  const StereoCamera cam = test_camera();
  const SE3 T1 = camera_at(Vector3d::Zero(), 0.0);
  const SE3 T2 = camera_at(Vector3d(0.1, 0.0, 0.0), 0.0);
  const Vector3d far(1.0, 0.5, 100.0);  // 10 cm baseline at 100 m: ~0.06 degrees of parallax
  const Vector2d x1 = normalize_pixel(cam, project(cam, T1, far).x(), project(cam, T1, far).y());
  const Vector2d x2 = normalize_pixel(cam, project(cam, T2, far).x(), project(cam, T2, far).y());
  EXPECT_GT(ray_parallax_cosine(T1, x1, T2, x2), kMaxParallaxCosine);
  EXPECT_FALSE(triangulate_checked(cam, {T1, project(cam, T1, far), 1.0}, {T2, project(cam, T2, far), 1.0}));

  const Vector3d near(1.0, 0.5, 3.0);  // same baseline at 3 m: ~1.9 degrees
  EXPECT_TRUE(triangulate_checked(cam, {T1, project(cam, T1, near), 1.0}, {T2, project(cam, T2, near), 1.0}));
}

TEST(OptimTriangulation, RejectsPointBehindACamera) {
  const StereoCamera cam = test_camera();
  const SE3 T1 = camera_at(Vector3d::Zero(), 0.0);
  const SE3 T2 = camera_at(Vector3d(-1.0, 0.0, 10.0), 0.0);  // beyond the point, looking the same way
  const Vector3d X(1.0, 0.2, 5.0);
  ASSERT_LT(depth_in_camera(T2, X), 0.0);
  // The pixel where camera 2 "sees" it (the mirrored projection) gives a good parallax and an exact
  // linear solution, so only the depth test can catch it.
  const Vector2d pixel2 = project(cam, T2, X);
  const std::optional<Vector3d> linear = triangulate_linear_pixels(cam, T1, project(cam, T1, X), T2, pixel2);
  ASSERT_TRUE(linear.has_value());
  EXPECT_LT((*linear - X).norm(), 1e-9);
  EXPECT_TRUE(has_positive_depth(T1, *linear));
  EXPECT_FALSE(has_positive_depth(T2, *linear));
  EXPECT_FALSE(triangulate_checked(cam, {T1, project(cam, T1, X), 1.0}, {T2, pixel2, 1.0}));
}

TEST(OptimTriangulation, ReprojectionTestUsesChi2TimesLevelSigma2) {
  const StereoCamera cam = test_camera();
  const SE3 T = camera_at(Vector3d(0.2, 0.0, 0.0), 0.1);
  const Vector3d X(0.5, -0.3, 4.0);
  const Vector2d pixel = project(cam, T, X);
  // 5.991 * sigma2 is the bound on the squared pixel error.
  EXPECT_TRUE(reprojection_within(cam, T, X, pixel.x() + 2.0, pixel.y(), 1.0));   // 4 <= 5.991
  EXPECT_FALSE(reprojection_within(cam, T, X, pixel.x() + 2.5, pixel.y(), 1.0));  // 6.25 > 5.991
  EXPECT_TRUE(reprojection_within(cam, T, X, pixel.x() + 2.5, pixel.y(), level_sigma2(1, 1.2)));
  EXPECT_FALSE(reprojection_within(cam, camera_at(Vector3d(0.0, 0.0, 10.0), 0.0), X, pixel.x(), pixel.y(),
                                   1.0));  // behind: never within
  const double u_right = pixel.x() - cam.bf() / (T * X).z();
  EXPECT_TRUE(stereo_reprojection_within(cam, T, X, pixel.x(), pixel.y(), u_right + 2.7, 1.0));   // 7.29
  EXPECT_FALSE(stereo_reprojection_within(cam, T, X, pixel.x(), pixel.y(), u_right + 2.9, 1.0));  // 8.41
}

TEST(OptimTriangulation, RejectsObservationsThatDoNotMeet) {
  const StereoCamera cam = test_camera();
  const SE3 T1 = camera_at(Vector3d::Zero(), 0.0);
  const SE3 T2 = camera_at(Vector3d(0.8, 0.0, 0.0), -0.05);
  const Vector3d X(0.4, 0.3, 5.0);
  const Vector2d bad = project(cam, T2, X) + Vector2d(0.0, 12.0);  // 12 px off the epipolar line
  EXPECT_FALSE(triangulate_checked(cam, {T1, project(cam, T1, X), 1.0}, {T2, bad, 1.0}));
  EXPECT_TRUE(triangulate_checked(cam, {T1, project(cam, T1, X), 1.0},
                                  {T2, project(cam, T2, X) + Vector2d(0.0, 1.0), 1.0}));
}

TEST(OptimTriangulation, StereoBackProjectionIsExact) {
  const StereoCamera cam = test_camera();
  const double u_left = 400.25, v = 120.5, disparity = 12.5;
  const std::optional<Vector3d> p_c = stereo_backproject_camera(cam, u_left, v, u_left - disparity);
  ASSERT_TRUE(p_c.has_value());
  EXPECT_DOUBLE_EQ(p_c->z(), cam.bf() / disparity);
  EXPECT_NEAR(cam.fx * p_c->x() / p_c->z() + cam.cx, u_left, 1e-12);
  EXPECT_NEAR(cam.fy * p_c->y() / p_c->z() + cam.cy, v, 1e-12);
  EXPECT_NEAR(cam.fx * p_c->x() / p_c->z() + cam.cx - cam.bf() / p_c->z(), u_left - disparity, 1e-12);

  const SE3 T_cw = camera_at(Vector3d(1.0, -2.0, 0.5), 0.7);
  const std::optional<Vector3d> p_w = stereo_backproject_world(cam, T_cw, u_left, v, u_left - disparity);
  ASSERT_TRUE(p_w.has_value());
  EXPECT_LT((T_cw * *p_w - *p_c).norm(), 1e-12);

  EXPECT_FALSE(stereo_backproject_camera(cam, u_left, v, u_left));        // zero disparity
  EXPECT_FALSE(stereo_backproject_camera(cam, u_left, v, u_left + 1.0));  // negative disparity
}

}  // namespace
}  // namespace porta::slam::optim

#endif  // PORTA_OPTIM_BUILT
