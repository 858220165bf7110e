// EPnP and its RANSAC (relocalisation): EPnP is exact on noise-free general and planar scenes, from
// the minimal 4 points up, and accurate with 1 px noise; it declines degenerate input. RANSAC
// recovers the pose with 30-50 % gross outliers and flags exactly the true inliers, reports nothing
// for meaningless input, rejects points behind the camera, weighs each pixel by its sigma2, and
// reruns bit-identically. Scenes are drawn with the solvers' own SplitMix64 (platform-independent).
#if PORTA_OPTIM_BUILT

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/slam/optim/pnp.hpp"
#include "geometry_scene.hpp"
#include "porta/slam/optim/ransac_random.hpp"

namespace porta::slam::optim {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

using test::deg;
using test::kitti_camera;
using test::SceneRng;

// T_cw with a rotation of up to 30 degrees about a random axis and a few metres of translation.
SE3 random_pose(SceneRng& rng) {
  Vector3d axis(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(deg(rng.uniform(-30.0, 30.0)), axis.normalized()).toRotationMatrix();
  T.translation() = Vector3d(rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0));
  return T;
}

Vector2d project(const StereoCamera& cam, const Vector3d& p) {
  return {cam.fx * p.x() / p.z() + cam.cx, cam.fy * p.y() / p.z() + cam.cy};
}

// A world scene seen by T_cw: points 2-30 m in front of the camera, inside its image.
struct Scene {
  std::vector<Vector3d> points_world;
  std::vector<Vector2d> uv;
  std::vector<double> sigma2;
};
Scene make_scene(SceneRng& rng, const StereoCamera& cam, const SE3& T_cw, int n, double pixel_noise = 0.0) {
  Scene s;
  for (int i = 0; i < n; ++i) {
    const double z = rng.uniform(2.0, 30.0);
    const Vector2d uv(rng.uniform(0.0, cam.width), rng.uniform(0.0, cam.height));
    const Vector3d p((uv.x() - cam.cx) * z / cam.fx, (uv.y() - cam.cy) * z / cam.fy, z);
    s.points_world.push_back(T_cw.inverse() * p);
    s.uv.push_back(uv + pixel_noise * Vector2d(rng.gaussian(), rng.gaussian()));
    s.sigma2.push_back(1.0);
  }
  return s;
}

// Replaces the pixel of point i by a random one at least 20 px from the true projection.
void make_outlier(SceneRng& rng, const StereoCamera& cam, Scene& s, std::size_t i) {
  const Vector2d truth = s.uv[i];
  while ((s.uv[i] - truth).norm() < 20.0)
    s.uv[i] = {rng.uniform(0.0, cam.width), rng.uniform(0.0, cam.height)};
}

double rotation_error_rad(const SE3& a, const SE3& b) {
  return rotation_angle_rad(a.linear() * b.linear().transpose());
}
double translation_error_m(const SE3& a, const SE3& b) { return (a.translation() - b.translation()).norm(); }

TEST(Epnp, ExactOnNoiseFreePoints) {
  SceneRng rng(31);
  const StereoCamera cam = kitti_camera();
  for (const int n : {6, 10, 50, 300}) {
    for (int trial = 0; trial < 10; ++trial) {
      const SE3 T_cw = random_pose(rng);
      const Scene s = make_scene(rng, cam, T_cw, n);
      const std::optional<SE3> found = solve_epnp(s.points_world, s.uv, cam);
      ASSERT_TRUE(found.has_value()) << "n " << n << " trial " << trial;
      EXPECT_LT(rotation_error_rad(*found, T_cw), 1e-9) << "n " << n << " trial " << trial;
      EXPECT_LT(translation_error_m(*found, T_cw), 1e-9) << "n " << n << " trial " << trial;
    }
  }
}

TEST(Epnp, ExactFromTheMinimalFourAndFivePoints) {
  // M's null space has 4 (2) dimensions: only the N = 4 (relinearised) or N = 2 solution is exact.
  SceneRng rng(32);
  const StereoCamera cam = kitti_camera();
  for (const int n : {4, 5}) {
    int exact = 0;
    for (int trial = 0; trial < 50; ++trial) {
      const SE3 T_cw = random_pose(rng);
      const Scene s = make_scene(rng, cam, T_cw, n);
      const std::optional<SE3> found = solve_epnp(s.points_world, s.uv, cam);
      ASSERT_TRUE(found.has_value()) << "n " << n << " trial " << trial;
      exact += rotation_error_rad(*found, T_cw) < 1e-6 && translation_error_m(*found, T_cw) < 1e-6 ? 1 : 0;
    }
    // 4 points: about 1 random scene in 500 (near-degenerate) ends within 1e-2 instead of exact.
    EXPECT_GE(exact, n == 5 ? 50 : 49) << "n " << n;
  }
}

TEST(Epnp, ExactOnPlanarPoints) {
  SceneRng rng(33);
  const StereoCamera cam = kitti_camera();
  for (const int n : {4, 8, 60}) {
    for (int trial = 0; trial < 10; ++trial) {
      const SE3 T_cw = random_pose(rng);
      Scene s;  // a wall 12 m in front of the camera at the identity, seen from T_cw
      while (static_cast<int>(s.uv.size()) < n) {
        const Vector3d X(rng.uniform(-8.0, 8.0), rng.uniform(-2.0, 2.0), 12.0);
        const Vector3d p = T_cw * X;
        if (!(p.z() > 1.0)) continue;
        s.points_world.push_back(X);
        s.uv.push_back(project(cam, p));
      }
      const std::optional<SE3> found = solve_epnp(s.points_world, s.uv, cam);
      ASSERT_TRUE(found.has_value()) << "n " << n << " trial " << trial;
      EXPECT_LT(rotation_error_rad(*found, T_cw), 1e-9) << "n " << n << " trial " << trial;
      EXPECT_LT(translation_error_m(*found, T_cw), 1e-9) << "n " << n << " trial " << trial;
    }
  }
}

TEST(Epnp, AccurateWithOnePixelNoise) {
  SceneRng rng(34);
  const StereoCamera cam = kitti_camera();
  for (int trial = 0; trial < 10; ++trial) {
    const SE3 T_cw = random_pose(rng);
    const Scene s = make_scene(rng, cam, T_cw, 100, 1.0);
    const std::optional<SE3> found = solve_epnp(s.points_world, s.uv, cam);
    ASSERT_TRUE(found.has_value());
    EXPECT_LT(rotation_error_rad(*found, T_cw), deg(0.2)) << "trial " << trial;
    EXPECT_LT(translation_error_m(*found, T_cw), 0.1) << "trial " << trial;  // scene depth 2-30 m
  }
}

TEST(Epnp, DeclinesTooFewMismatchedCoincidentOrCollinearPoints) {
  SceneRng rng(35);
  const StereoCamera cam = kitti_camera();
  const Scene s = make_scene(rng, cam, SE3::Identity(), 10);
  const std::span<const Vector3d> points(s.points_world);
  const std::span<const Vector2d> uv(s.uv);
  EXPECT_FALSE(solve_epnp(points.first(3), uv.first(3), cam).has_value());
  EXPECT_FALSE(solve_epnp(points.first(6), uv.first(5), cam).has_value());
  const std::vector<Vector3d> coincident(6, Vector3d(1.0, 0.5, 10.0));
  EXPECT_FALSE(solve_epnp(coincident, uv.first(6), cam).has_value());
  std::vector<Vector3d> collinear;
  std::vector<Vector2d> collinear_uv;
  for (int i = 0; i < 8; ++i) {
    collinear.push_back(Vector3d(-1.0, 0.5, 5.0) + i * Vector3d(0.4, -0.1, 2.0));
    collinear_uv.push_back(project(cam, collinear.back()));
  }
  EXPECT_FALSE(solve_epnp(collinear, collinear_uv, cam).has_value());
}

TEST(PnpRansac, RecoversExactPoseFromNoiseFreePoints) {
  SceneRng rng(41);
  const StereoCamera cam = kitti_camera();
  for (int trial = 0; trial < 5; ++trial) {
    const SE3 T_cw = random_pose(rng);
    const Scene s = make_scene(rng, cam, T_cw, 80);
    const PnpRansacResult r = solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2);
    ASSERT_TRUE(r.found);
    EXPECT_EQ(r.num_inliers, 80);
    EXPECT_LT(rotation_error_rad(r.T_cw, T_cw), 1e-9);
    EXPECT_LT(translation_error_m(r.T_cw, T_cw), 1e-9);
  }
}

TEST(PnpRansac, AccurateWithOnePixelNoise) {
  SceneRng rng(42);
  const StereoCamera cam = kitti_camera();
  for (int trial = 0; trial < 5; ++trial) {
    const SE3 T_cw = random_pose(rng);
    const Scene s = make_scene(rng, cam, T_cw, 200, 1.0);
    const PnpRansacResult r = solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2);
    ASSERT_TRUE(r.found);
    EXPECT_GT(r.num_inliers, 160) << "trial " << trial;  // chi2 5.991 keeps 95 % of 1 px noise
    EXPECT_LT(rotation_error_rad(r.T_cw, T_cw), deg(0.2)) << "trial " << trial;
    EXPECT_LT(translation_error_m(r.T_cw, T_cw), 0.1) << "trial " << trial;  // scene depth 2-30 m
  }
}

TEST(PnpRansac, RecoversPoseWith30To50PercentOutliersAndFlagsThem) {
  SceneRng rng(43);
  const StereoCamera cam = kitti_camera();
  for (const double outlier_ratio : {0.3, 0.4, 0.5}) {
    const SE3 T_cw = random_pose(rng);
    Scene s = make_scene(rng, cam, T_cw, 150);
    std::vector<bool> truth(s.uv.size(), true);
    for (std::size_t i = 0; i < s.uv.size(); ++i) {
      if (rng.uniform(0.0, 1.0) >= outlier_ratio) continue;
      make_outlier(rng, cam, s, i);
      truth[i] = false;
    }
    const PnpRansacResult r = solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2);
    ASSERT_TRUE(r.found) << "outliers " << outlier_ratio;
    EXPECT_EQ(r.inlier, truth) << "outliers " << outlier_ratio;
    EXPECT_EQ(r.num_inliers, static_cast<int>(std::count(truth.begin(), truth.end(), true)));
    EXPECT_LT(rotation_error_rad(r.T_cw, T_cw), 1e-9);
    EXPECT_LT(translation_error_m(r.T_cw, T_cw), 1e-9);
  }
}

TEST(PnpRansac, AllOutliersAreNotFound) {
  SceneRng rng(44);
  const StereoCamera cam = kitti_camera();
  Scene s = make_scene(rng, cam, random_pose(rng), 100);
  for (Vector2d& uv : s.uv) uv = {rng.uniform(0.0, cam.width), rng.uniform(0.0, cam.height)};
  const PnpRansacResult r = solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2);
  EXPECT_FALSE(r.found);
  EXPECT_LT(r.num_inliers, 10);
  EXPECT_EQ(r.iterations, PnpRansacOptions{}.max_iterations);
}

TEST(PnpRansac, TooFewOrCollinearPointsAreNotFound) {
  SceneRng rng(45);
  const StereoCamera cam = kitti_camera();
  const Scene few = make_scene(rng, cam, SE3::Identity(), 9);  // min_inliers 10
  const PnpRansacResult r_few = solve_pnp_ransac(cam, few.points_world, few.uv, few.sigma2);
  EXPECT_FALSE(r_few.found);
  EXPECT_EQ(r_few.iterations, 0);
  EXPECT_EQ(r_few.inlier, std::vector<bool>(9, false));

  Scene line;  // every sample is degenerate
  for (int i = 0; i < 30; ++i) {
    line.points_world.push_back(Vector3d(-1.0, 0.5, 5.0) + i * Vector3d(0.1, -0.02, 0.5));
    line.uv.push_back(project(cam, line.points_world.back()));
    line.sigma2.push_back(1.0);
  }
  const PnpRansacResult r_line = solve_pnp_ransac(cam, line.points_world, line.uv, line.sigma2);
  EXPECT_FALSE(r_line.found);
  EXPECT_EQ(r_line.num_inliers, 0);
}

TEST(PnpRansac, PointsBehindTheCameraAreOutliers) {
  SceneRng rng(46);
  const StereoCamera cam = kitti_camera();
  const SE3 T_cw = random_pose(rng);
  Scene s = make_scene(rng, cam, T_cw, 60);
  // Mirrored through the camera centre: the same pixel, but behind the camera.
  for (int i = 0; i < 10; ++i) s.points_world[i] = T_cw.inverse() * (-(T_cw * s.points_world[i]));
  const PnpRansacResult r = solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2);
  ASSERT_TRUE(r.found);
  for (int i = 0; i < 60; ++i) EXPECT_EQ(r.inlier[i], i >= 10) << "point " << i;
  EXPECT_LT(rotation_error_rad(r.T_cw, T_cw), 1e-9);
}

TEST(PnpRansac, InlierBoundScalesWithEachSigma2) {
  SceneRng rng(47);
  const StereoCamera cam = kitti_camera();
  const SE3 T_cw = random_pose(rng);
  Scene s = make_scene(rng, cam, T_cw, 40);
  s.uv[0].x() += 3.0;  // 9 px^2: above 5.991 * 1, below 5.991 * 4 (a keypoint one octave up)
  s.uv[1].x() += 3.0;
  s.sigma2[1] = 4.0;
  const PnpRansacResult r = solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2);
  ASSERT_TRUE(r.found);
  EXPECT_FALSE(r.inlier[0]);
  EXPECT_TRUE(r.inlier[1]);
  EXPECT_EQ(r.num_inliers, 39);
}

TEST(PnpRansac, InvalidOptionsSizesAndSigmasThrow) {
  SceneRng rng(48);
  const StereoCamera cam = kitti_camera();
  Scene s = make_scene(rng, cam, SE3::Identity(), 20);
  const auto throws_naming = [&](const PnpRansacOptions& o, const char* field) {
    try {
      solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2, o);
      ADD_FAILURE() << "no exception for " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  throws_naming({.probability = 0.0}, "probability");
  throws_naming({.probability = 1.5}, "probability");
  throws_naming({.min_inliers = 3}, "min_inliers");
  throws_naming({.max_iterations = 0}, "max_iterations");
  throws_naming({.min_set = 3}, "min_set");
  throws_naming({.chi2 = -1.0}, "chi2");
  s.sigma2[4] = -1.0;
  throws_naming({}, "sigma2[4]");
  s.sigma2[4] = 1.0;
  s.sigma2.pop_back();
  throws_naming({}, "sizes");
}

TEST(PnpRansac, SameSeedGivesBitIdenticalResults) {
  SceneRng rng(49);
  const StereoCamera cam = kitti_camera();
  const SE3 T_cw = random_pose(rng);
  Scene s = make_scene(rng, cam, T_cw, 120, 1.0);
  for (std::size_t i = 0; i < s.uv.size(); i += 3) make_outlier(rng, cam, s, i);
  const PnpRansacOptions options{.seed = 7};
  const PnpRansacResult first = solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2, options);
  const PnpRansacResult second = solve_pnp_ransac(cam, s.points_world, s.uv, s.sigma2, options);
  ASSERT_TRUE(first.found);
  EXPECT_EQ(std::memcmp(first.T_cw.matrix().data(), second.T_cw.matrix().data(), sizeof(double) * 16), 0);
  EXPECT_EQ(first.inlier, second.inlier);
  EXPECT_EQ(first.num_inliers, second.num_inliers);
  EXPECT_EQ(first.iterations, second.iterations);
}

}  // namespace
}  // namespace porta::slam::optim

#endif  // PORTA_OPTIM_BUILT
