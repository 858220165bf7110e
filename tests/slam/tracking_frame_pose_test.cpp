// Tracking's pose-only optimisation of a frame (slam/tracking/frame_search.hpp, optimize_frame_pose)
// and its stereo depth limit: a frame relocalised from lost sees the map from where the map was not
// built, and there the far points' stereo depths disagree with the map (docs/BENCHMARKS.md, the
// covered lens: 5.7 cm along the optical axis). Beyond the limit a feature counts by its left-image
// position only. The scene is a street seen down its length, as the street loop's camera sees the
// loop's start when the lens is uncovered 12 m before it.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <vector>

#include "porta/slam/frame.hpp"
#include "porta/slam/map.hpp"
#include "porta/tables.hpp"
#include "slam/tracking/frame_search.hpp"

namespace porta::slam {
namespace {

constexpr double kNoLimit = std::numeric_limits<double>::infinity();

/// KITTI's rectified camera (fx 718.856, baseline 0.537 m) and map points on two facades 4 m either
/// side of the camera, `near_m` to `far_m` ahead, observed on level 0 at their exact image positions,
/// all with a stereo match whose disparity reads `disparity_bias_px` wider than the truth.
struct Street {
  StereoCamera camera{1242, 375, 718.856, 718.856, 607.19, 185.22, 0.537};
  ScalePyramid pyramid{8, 1.2};
  std::vector<std::int32_t> scales_q16 = build_level_scales_q16(8, 1.2);
  std::vector<std::unique_ptr<MapPoint>> points;
  std::shared_ptr<FrameFeatures> features = std::make_shared<FrameFeatures>();

  Street(double near_m, double far_m, double disparity_bias_px) {
    for (int side = -1; side <= 1; side += 2) {
      for (int row = 0; row < 4; ++row) {
        for (double z = near_m; z <= far_m; z += 2.5) {
          const Eigen::Vector3d p(4.0 * side + 0.3 * row, -1.0 + 1.1 * row, z + 0.4 * row);
          const double u = camera.fx * p.x() / p.z() + camera.cx, v = camera.fy * p.y() / p.z() + camera.cy;
          if (u < 0.0 || u >= camera.width || v < 0.0 || v >= camera.height) continue;
          const double disparity = camera.bf() / p.z() + disparity_bias_px;
          points.push_back(std::make_unique<MapPoint>(points.size(), p, nullptr, 0));
          features->uv.emplace_back(static_cast<float>(u), static_cast<float>(v));
          features->level.push_back(0);
          features->angle_rad.push_back(0.0f);
          features->descriptors.emplace_back();
          features->u_right.push_back(static_cast<float>(u - disparity));
          features->depth_m.push_back(static_cast<float>(camera.bf() / disparity));
        }
      }
    }
  }

  /// A frame matched to every point, its pose first guessed 10 cm and 0.3 degrees off the truth
  /// (the identity).
  Frame frame() const {
    Frame f(0, 0.0, features, camera);
    f.points.clear();
    for (const auto& p : points) f.points.push_back(p.get());
    f.outlier.assign(points.size(), false);
    f.T_cw = SE3::Identity();
    f.T_cw.linear() = Eigen::AngleAxisd(0.3 * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
    f.T_cw.translation() = Eigen::Vector3d(0.03, -0.02, 0.1);
    return f;
  }

  tracking::SearchGeometry geometry() const { return {camera, pyramid, scales_q16}; }
};

double position_error_m(const Frame& f) { return f.T_cw.inverse().translation().norm(); }

TEST(FramePose, FarStereoDepthsBeyondTheLimitCountByTheirImagePositionOnly) {
  // 25-100 m ahead, every disparity 1 px too wide: inside the stereo inlier gate (2.8 px at level 0).
  const Street street(25.0, 100.0, 1.0);
  ASSERT_GT(street.points.size(), 100u);
  const double limit_m = 35.0 * street.camera.baseline_m;  // th_depth * baseline: 18.8 m
  Frame limited = street.frame();
  const int inliers = tracking::optimize_frame_pose(limited, street.geometry(), limit_m);
  EXPECT_EQ(inliers, static_cast<int>(street.points.size()));
  EXPECT_LT(position_error_m(limited), 0.002) << "far points by their image positions: the true pose";

  // The same features without a stereo match give the same bytes: beyond the limit, u_right is unread.
  auto mono = std::make_shared<FrameFeatures>(*street.features);
  for (std::size_t i = 0; i < mono->size(); ++i) mono->u_right[i] = -1.0f, mono->depth_m[i] = -1.0f;
  Frame without_stereo = street.frame();
  without_stereo.features = mono;
  tracking::optimize_frame_pose(without_stereo, street.geometry());
  EXPECT_EQ(std::memcmp(limited.T_cw.data(), without_stereo.T_cw.data(), sizeof(double) * 16), 0);

  // Without the limit the biased depths pull the camera forward along its axis (1.6 cm here): what
  // the limit is for (this fails if the limit is ignored).
  Frame unlimited = street.frame();
  tracking::optimize_frame_pose(unlimited, street.geometry(), kNoLimit);
  const Eigen::Vector3d centre = unlimited.T_cw.inverse().translation();
  EXPECT_GT(centre.z(), 0.01) << "1 px of disparity over 25-100 m should move the pose forward";
  EXPECT_LT(std::abs(centre.x()), 0.5 * centre.z());
}

TEST(FramePose, StereoDepthsWithinTheLimitStillCount) {
  // 5-18 m ahead, all within 18.8 m: the limit changes nothing, and an exact stereo match holds
  // the pose as before.
  const Street street(5.0, 18.0, 0.0);
  Frame limited = street.frame(), unlimited = street.frame();
  tracking::optimize_frame_pose(limited, street.geometry(), 35.0 * street.camera.baseline_m);
  tracking::optimize_frame_pose(unlimited, street.geometry(), kNoLimit);
  EXPECT_EQ(std::memcmp(limited.T_cw.data(), unlimited.T_cw.data(), sizeof(double) * 16), 0);
  EXPECT_LT(position_error_m(limited), 0.002);
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
