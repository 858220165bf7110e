// The renderer's geometry is ground truth: depth, projection and stereo disparity of rendered
// images must be exact (slam/render).
#if PORTA_RENDER_BUILT
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "porta/slam/render/camera_path.hpp"
#include "porta/slam/render/rasterizer.hpp"
#include "porta/slam/render/texture.hpp"
#include "porta/slam/render/world.hpp"

namespace porta::slam::render {
namespace {

// A world of one textured quad facing the camera (at the origin looking along +y of a z-up world).
World wall_world(double distance_m, double half_size_m, Material material = Material::patterned) {
  World w;
  Surface s;
  s.material = material;
  s.texels_per_m = 120.0f;
  s.gain = 1.5f;
  w.surfaces.push_back(s);
  Polygon p;
  const Eigen::Vector3d o(-half_size_m, distance_m, -half_size_m);
  p.vertex = {o, o + Eigen::Vector3d(2 * half_size_m, 0, 0), o + Eigen::Vector3d(2 * half_size_m, 0, 2 * half_size_m),
              o + Eigen::Vector3d(0, 0, 2 * half_size_m)};
  p.origin = o;
  p.axis_u = Eigen::Vector3d::UnitX();
  p.axis_v = Eigen::Vector3d::UnitZ();
  w.add(p);
  w.build_index();
  return w;
}

// Camera at `eye` looking along +y (x right, y down = -z).
Eigen::Isometry3d camera_looking_north(const Eigen::Vector3d& eye) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d::UnitX();
  R.col(1) = -Eigen::Vector3d::UnitZ();
  R.col(2) = Eigen::Vector3d::UnitY();
  T.linear() = R;
  T.translation() = eye;
  return T;
}

const PinholeView kView{96, 64, 80.0, 80.0, 47.5, 31.5};

TEST(RenderGeometry, FrontoParallelWallHasExactDepthEverywhere) {
  const World w = wall_world(4.0, 50.0);
  Rasterizer r;
  const auto depth = r.depth_map(w, kView, camera_looking_north({0, 0, 0}));
  for (const DepthSample& d : depth) {
    ASSERT_EQ(d.polygon, 0);
    EXPECT_NEAR(d.depth_m, 4.0, 1e-5);
  }
}

TEST(RenderGeometry, KnownWorldPointProjectsToExpectedPixel) {
  // A small quad around world point P; it must cover exactly the pixel P projects to.
  World w = wall_world(20.0, 100.0);
  // Chosen to project onto the centre of pixel (59, 38): x = (59 - cx) * z / fx, y = (38 - cy) * z / fy.
  const Eigen::Vector3d P(0.71875, 5.0, -0.40625);  // right, 5 m ahead, below the eye
  Polygon q = w.polygons[0];
  const double h = 0.01;
  q.vertex = {P + Eigen::Vector3d(-h, 0, -h), P + Eigen::Vector3d(h, 0, -h), P + Eigen::Vector3d(h, 0, h),
              P + Eigen::Vector3d(-h, 0, h)};
  w.add(q);
  w.build_index();
  Rasterizer r;
  const auto depth = r.depth_map(w, kView, camera_looking_north({0, 0, 0}));
  const double u = kView.fx * 0.71875 / 5.0 + kView.cx, v = kView.fy * 0.40625 / 5.0 + kView.cy;
  EXPECT_DOUBLE_EQ(u, 59.0);
  EXPECT_DOUBLE_EQ(v, 38.0);
  const int px = static_cast<int>(std::lround(u)), py = static_cast<int>(std::lround(v));
  const DepthSample& hit = depth[static_cast<std::size_t>(py) * kView.width + px];
  EXPECT_EQ(hit.polygon, 1) << "pixel " << px << "," << py;
  EXPECT_NEAR(hit.depth_m, 5.0, 1e-5);
  int covered = 0;
  for (const auto& d : depth) covered += d.polygon == 1;
  EXPECT_EQ(covered, 1);  // 2 cm at 5 m is 0.32 px: only the pixel whose centre it covers
}

TEST(RenderGeometry, PolygonCrossingTheCameraPlaneIsClippedNotLost) {
  // A floor quad from 10 m behind to 10 m ahead, 1 m below the eye: the lower half of the image.
  World w;
  w.surfaces.push_back(Surface{});
  Polygon floor;
  floor.vertex = {Eigen::Vector3d(-10, -10, -1), Eigen::Vector3d(10, -10, -1), Eigen::Vector3d(10, 10, -1),
                  Eigen::Vector3d(-10, 10, -1)};
  w.add(floor);
  w.build_index();
  Rasterizer r;
  const auto depth = r.depth_map(w, kView, camera_looking_north({0, 0, 0}));
  for (int y = 0; y < kView.height; ++y)
    for (int x = 0; x < kView.width; ++x) {
      const DepthSample& d = depth[static_cast<std::size_t>(y) * kView.width + x];
      const double ray_y = (y - kView.cy) / kView.fy;  // camera y per unit depth
      const double z = ray_y > 0 ? 1.0 / ray_y : 1e9;   // where the ray meets the floor
      const double ray_x = (x - kView.cx) / kView.fx;
      const bool on_floor = ray_y > 0 && z <= 10.0 && std::abs(ray_x * z) <= 10.0;
      if (!on_floor) continue;
      ASSERT_EQ(d.polygon, 0) << x << "," << y;
      EXPECT_NEAR(d.depth_m, z, 1e-4 * z);
    }
}

// Disparity by SAD block matching with a parabola fit, at (x, y) of the left image.
double block_match(const std::vector<float>& left, const std::vector<float>& right, int width, int x, int y, int max_d) {
  const int r = 5;
  std::vector<double> cost(static_cast<std::size_t>(max_d) + 1);
  for (int d = 0; d <= max_d; ++d) {
    double sad = 0;
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx)
        sad += std::abs(left[static_cast<std::size_t>(y + dy) * width + x + dx] - right[static_cast<std::size_t>(y + dy) * width + x + dx - d]);
    cost[static_cast<std::size_t>(d)] = sad;
  }
  const int best = static_cast<int>(std::min_element(cost.begin(), cost.end()) - cost.begin());
  if (best == 0 || best == max_d) return best;
  const double a = cost[static_cast<std::size_t>(best) - 1], b = cost[static_cast<std::size_t>(best)], c = cost[static_cast<std::size_t>(best) + 1];
  return best + 0.5 * (a - c) / (a - 2 * b + c);
}

TEST(RenderGeometry, StereoDisparityOfAPlaneIsFxTimesBaselineOverDepth) {
  const TextureBank textures(7, 128, 1);
  const double z = 3.0, baseline = 0.3;  // disparity 80 * 0.3 / 3 = 8 px
  const World w = wall_world(z, 50.0);
  Rasterizer r;
  std::vector<float> left, right;
  const Eigen::Isometry3d T_left = camera_looking_north({0, 0, 0});
  Eigen::Isometry3d T_right = T_left * Eigen::Translation3d(baseline, 0, 0);
  r.render(w, textures, kView, T_left, 2, left);
  r.render(w, textures, kView, T_right, 2, right);
  std::vector<double> errors;
  for (int y = 8; y < kView.height - 8; y += 6)
    for (int x = 30; x < kView.width - 8; x += 6)
      errors.push_back(std::abs(block_match(left, right, kView.width, x, y, 16) - kView.fx * baseline / z));
  std::sort(errors.begin(), errors.end());
  ASSERT_GT(errors.size(), 40u);
  EXPECT_LT(errors[errors.size() / 2], 0.1);         // median
  EXPECT_LT(errors[errors.size() * 9 / 10], 0.25);  // 90th percentile
}

TEST(RenderTexture, EveryMaterialHasStructureEverywhere) {
  // Local standard deviation over 16x16 windows is above 4 grey levels in > 95 % of the windows.
  for (int m = 0; m < kMaterialCount; ++m) {
    const int size = 128;
    const std::vector<float> t = generate_texture(static_cast<Material>(m), size, 3);
    int windows = 0, structured = 0;
    for (int y = 0; y < size; y += 16)
      for (int x = 0; x < size; x += 16) {
        double s = 0, s2 = 0;
        for (int dy = 0; dy < 16; ++dy)
          for (int dx = 0; dx < 16; ++dx) {
            const double v = t[static_cast<std::size_t>(y + dy) * size + x + dx];
            s += v, s2 += v * v;
          }
        const double mean = s / 256, sd = std::sqrt(std::max(0.0, s2 / 256 - mean * mean));
        ++windows;
        structured += sd > 4.0;
      }
    EXPECT_GT(structured, windows * 95 / 100) << "material " << m;
  }
}

TEST(RenderTexture, MipLevelsAverageAndSamplingWraps) {
  std::vector<float> level0(16 * 16);
  for (int i = 0; i < 256; ++i) level0[static_cast<std::size_t>(i)] = static_cast<float>((i % 16 + i / 16) % 2 ? 200 : 100);
  const MipTexture t(16, level0);
  EXPECT_EQ(t.levels(), 5);
  EXPECT_NEAR(t.mean(), 150.0f, 0.5f);
  EXPECT_NEAR(t.sample(1, 5.0f, 7.0f), 150.0f, 0.5f);           // the checkerboard averages out
  EXPECT_FLOAT_EQ(t.sample(0, 0.5f, 0.5f), t.sample(0, 16.5f, -15.5f));  // wraps
  EXPECT_EQ(mip_level_for(0.5f, 5), 0);
  EXPECT_EQ(mip_level_for(3.9f, 5), 1);
  EXPECT_EQ(mip_level_for(1000.0f, 5), 4);
}

TEST(RenderPath, StreetLoopIsClosedAndInterpolationIsExactAtEnds) {
  const Trajectory loop = builtin_path(BuiltinPath::street_loop);
  ASSERT_GT(loop.size(), 400u);
  EXPECT_LT((loop.poses.front().pose.translation() - loop.poses.back().pose.translation()).norm(), 1e-6);
  EXPECT_GT(loop.path_length_m(), 400.0);
  const SE3 a = loop.poses[10].pose, b = loop.poses[11].pose;
  EXPECT_TRUE(interpolate_pose(a, b, 0.0).isApprox(a, 1e-12));
  EXPECT_TRUE(interpolate_pose(a, b, 1.0).isApprox(b, 1e-9));
  const Trajectory resampled = resample(loop, 20.0);
  EXPECT_NEAR(static_cast<double>(resampled.size()), 2.0 * loop.size() - 1, 1.0);
  EXPECT_TRUE(resampled.poses[2].pose.isApprox(loop.poses[1].pose, 1e-9));
}

TEST(RenderPath, UpAxisConventions) {
  // KITTI: up is -y; the camera's forward (z) stays horizontal, its down (y) maps to -z.
  const Eigen::Matrix3d R = render_from_input(*parse_axis("-y"));
  EXPECT_TRUE((R * Eigen::Vector3d(0, -1, 0)).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_NEAR((R * Eigen::Vector3d::UnitZ()).z(), 0.0, 1e-12);
  EXPECT_FALSE(parse_axis("w").has_value());
  // EuRoC cam0 looks roughly along the body's z axis.
  EXPECT_GT(euroc_T_body_cam0().rotation().col(2).z(), 0.99);
}

TEST(RenderWorld, RoomContainsThePathAndTheCameraNeverSeesOutside) {
  const Trajectory orbit = builtin_path(BuiltinPath::room_orbit);
  PathSamples path;
  for (const auto& p : orbit.poses) path.positions.push_back(p.pose.translation());
  const auto [lo, hi] = room_bounds(path);
  for (const auto& p : path.positions) {
    EXPECT_TRUE((p.array() > lo.array() + 0.5).all() && (p.array() < hi.array() - 0.5).all());
  }
  EXPECT_EQ(lo.z(), 0.0);
  const World w = build_room_world(path, 5);
  Rasterizer r;
  const PinholeView view{40, 30, 20.0, 20.0, 19.5, 14.5};  // wide angle
  for (std::size_t k = 0; k < orbit.size(); k += 97) {
    const auto depth = r.depth_map(w, view, orbit.poses[k].pose);
    for (const auto& d : depth) ASSERT_GE(d.polygon, 0) << "frame " << k << " sees outside the room";
  }
}

TEST(RenderWorld, StreetIsOneWorldWhenDrivenTwice) {
  // Driving the same street twice (0.4 m apart) gives the same buildings as driving it once.
  PathSamples once, twice;
  for (int k = 0; k <= 100; ++k) once.positions.emplace_back(k * 1.0, 0.0, 1.65);
  twice = once;
  for (int k = 100; k >= 0; --k) twice.positions.emplace_back(k * 1.0, 0.4, 1.65);
  const World a = build_street_world(once, 9), b = build_street_world(twice, 9);
  const auto buildings = [](const World& w) {
    int n = 0;
    for (const auto& p : w.polygons) n += w.surfaces[static_cast<std::size_t>(p.surface)].overlay == Overlay::windows;
    return n;
  };
  EXPECT_GT(buildings(a), 50);
  EXPECT_NEAR(buildings(a), buildings(b), buildings(a) * 0.1);
  EXPECT_LT(std::abs(static_cast<double>(a.polygons.size()) - static_cast<double>(b.polygons.size())), a.polygons.size() * 0.1);
}

}  // namespace
}  // namespace porta::slam::render
#endif
