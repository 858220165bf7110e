// Renders one pinhole view of a World: polygons are clipped at the near plane, scan-converted at
// k x k supersampled resolution into an inverse-depth buffer (per-pixel depth from each polygon's
// exact plane equation), then every sample is shaded once (deferred) from its polygon's texture
// frame, and k x k blocks are averaged. One Rasterizer per thread: it owns its buffers.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "porta/slam/render/texture.hpp"
#include "porta/slam/render/world.hpp"

namespace porta::slam::render {

/// A pinhole camera (pixels; x right, y down, z forward), no distortion.
struct PinholeView {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

/// What a rendered view saw at one output pixel's centre, for tests and ground truth.
struct DepthSample {
  float depth_m = 0;  ///< 0 where no polygon was hit (sky)
  int polygon = -1;   ///< world polygon index, -1 for none
};

/// Per-view coefficients of a drawn polygon at supersampled pixel (i, j): inverse depth
/// w = a i + b j + c, texture coordinates (m) u = (pu0 i + pu1 j + pu2) / w + pu3, v likewise.
struct ViewPolygon {
  float a = 0, b = 0, c = 0;
  float pu[4] = {0, 0, 0, 0}, pv[4] = {0, 0, 0, 0};
  int polygon = -1;
  const Surface* surface = nullptr;
};

class Rasterizer {
 public:
  static constexpr double kNearPlaneM = 0.05;

  /// Renders `world` seen from T_world_cam (z-up world) into `out` (width*height grey levels,
  /// unclamped floats), averaging supersample x supersample samples per pixel.
  void render(const World& world, const TextureBank& textures, const PinholeView& view, const Eigen::Isometry3d& T_world_cam,
              int supersample, std::vector<float>& out);
  /// Depth and polygon at every output pixel centre (rendered with supersample 1), row-major.
  std::vector<DepthSample> depth_map(const World& world, const PinholeView& view, const Eigen::Isometry3d& T_world_cam);

 private:
  void rasterize(const World& world, const PinholeView& view, const Eigen::Isometry3d& T_world_cam, int supersample);

  int width_ = 0, height_ = 0;  // of the supersampled buffers
  std::vector<float> inv_depth_;
  std::vector<std::int32_t> slot_;
  std::vector<int> candidates_;
  std::vector<ViewPolygon> visible_;
};

}  // namespace porta::slam::render
