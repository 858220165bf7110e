// Scan conversion with an inverse-depth buffer and deferred shading (rasterizer.hpp).
//
// Supersampled pixel (i, j) has its centre at output pixel ((i + 0.5) / k - 0.5, (j + 0.5) / k - 0.5),
// so the mean of a k x k block is centred exactly on its output pixel: the supersampled camera has
// fx' = k fx, cx' = k (cx + 0.5) - 0.5. A sample (i, j) is inside a polygon when its centre is, with
// half-open spans [ceil(x_left), ceil(x_right)) computed the same way on both sides of a shared edge,
// so neighbouring polygons leave neither gaps nor double coverage.
#include "porta/slam/render/rasterizer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "shading.hpp"

namespace porta::slam::render {

namespace {

struct ScreenVertex {
  double x, y;
};

// Clips a convex polygon (camera coordinates) to z >= near. Intersections are computed from the
// edge's endpoints in a canonical order so that two polygons sharing an edge get the same point.
int clip_near(const std::array<Eigen::Vector3d, 4>& in, int n, double near, std::array<Eigen::Vector3d, 8>& out) {
  int m = 0;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d& a = in[static_cast<std::size_t>(k)];
    const Eigen::Vector3d& b = in[static_cast<std::size_t>((k + 1) % n)];
    const bool a_in = a.z() >= near, b_in = b.z() >= near;
    if (a_in) out[static_cast<std::size_t>(m++)] = a;
    if (a_in != b_in) {
      const bool a_first = std::tie(a.x(), a.y(), a.z()) < std::tie(b.x(), b.y(), b.z());
      const Eigen::Vector3d& p = a_first ? a : b;
      const Eigen::Vector3d& q = a_first ? b : a;
      const double t = (near - p.z()) / (q.z() - p.z());
      Eigen::Vector3d x = p + t * (q - p);
      x.z() = near;
      out[static_cast<std::size_t>(m++)] = x;
    }
  }
  return m;
}

}  // namespace

void Rasterizer::rasterize(const World& world, const PinholeView& view, const Eigen::Isometry3d& T_world_cam, int k) {
  if (view.width < 1 || view.height < 1 || k < 1) throw std::invalid_argument("Rasterizer: empty view or supersample < 1");
  width_ = view.width * k;
  height_ = view.height * k;
  const std::size_t samples = static_cast<std::size_t>(width_) * height_;
  inv_depth_.assign(samples, 0.0f);
  slot_.assign(samples, -1);
  visible_.clear();

  const double fx = view.fx * k, fy = view.fy * k, cx = k * (view.cx + 0.5) - 0.5, cy = k * (view.cy + 0.5) - 0.5;
  const Eigen::Matrix3d R_cw = T_world_cam.rotation().transpose();
  const Eigen::Vector3d t = T_world_cam.translation();
  world.collect(t, world.view_range_m, candidates_);

  std::array<Eigen::Vector3d, 4> cam{};
  std::array<Eigen::Vector3d, 8> clipped{};
  std::array<ScreenVertex, 8> screen{};
  for (int index : candidates_) {
    const Polygon& poly = world.polygons[static_cast<std::size_t>(index)];
    // Frustum rejection in camera coordinates (all vertices outside one plane).
    int behind = 0, left = 0, right = 0, top = 0, bottom = 0;
    double nearest = std::numeric_limits<double>::infinity();
    for (int v = 0; v < poly.count; ++v) {
      const Eigen::Vector3d X = R_cw * (poly.vertex[static_cast<std::size_t>(v)] - t);
      cam[static_cast<std::size_t>(v)] = X;
      behind += X.z() < kNearPlaneM;
      left += fx * X.x() + (cx + 0.5) * X.z() < 0;
      right += fx * X.x() + (cx - width_ + 0.5) * X.z() > 0;
      top += fy * X.y() + (cy + 0.5) * X.z() < 0;
      bottom += fy * X.y() + (cy - height_ + 0.5) * X.z() > 0;
      nearest = std::min(nearest, X.norm());
    }
    const int n_in = poly.count;
    if (behind == n_in || left == n_in || right == n_in || top == n_in || bottom == n_in) continue;
    if (nearest > world.view_range_m) continue;

    // Plane: n . X = d in camera coordinates; inverse depth w = (n . r) / d for r = K^-1 (i, j, 1).
    const Eigen::Vector3d normal = (cam[1] - cam[0]).cross(cam[2] - cam[0]);
    if (normal.squaredNorm() == 0.0) continue;
    const Eigen::Vector3d nrm = normal.normalized();
    const double d = nrm.dot(cam[0]);
    if (std::abs(d) < 1e-9) continue;  // seen exactly edge-on
    ViewPolygon vp;
    vp.a = static_cast<float>(nrm.x() / (fx * d));
    vp.b = static_cast<float>(nrm.y() / (fy * d));
    vp.c = static_cast<float>((nrm.z() - nrm.x() * cx / fx - nrm.y() * cy / fy) / d);
    // Texture coordinates: u = (P - o) . U with P = R X + t, i.e. X . (R^T U) + (t - o) . U.
    const auto coefficients = [&](const Eigen::Vector3d& axis, float* p) {
      const Eigen::Vector3d A = R_cw * axis;
      p[0] = static_cast<float>(A.x() / fx);
      p[1] = static_cast<float>(A.y() / fy);
      p[2] = static_cast<float>(A.z() - A.x() * cx / fx - A.y() * cy / fy);
      p[3] = static_cast<float>((t - poly.origin).dot(axis));
    };
    coefficients(poly.axis_u, vp.pu);
    coefficients(poly.axis_v, vp.pv);
    vp.polygon = index;
    vp.surface = &world.surfaces[static_cast<std::size_t>(poly.surface)];

    const int m = behind > 0 ? clip_near(cam, n_in, kNearPlaneM, clipped) : n_in;
    if (behind == 0) std::copy(cam.begin(), cam.begin() + n_in, clipped.begin());
    if (m < 3) continue;
    double ymin = std::numeric_limits<double>::infinity(), ymax = -ymin;
    for (int v = 0; v < m; ++v) {
      const Eigen::Vector3d& X = clipped[static_cast<std::size_t>(v)];
      screen[static_cast<std::size_t>(v)] = {fx * X.x() / X.z() + cx, fy * X.y() / X.z() + cy};
      ymin = std::min(ymin, screen[static_cast<std::size_t>(v)].y);
      ymax = std::max(ymax, screen[static_cast<std::size_t>(v)].y);
    }
    const int row0 = std::max(0, static_cast<int>(std::ceil(ymin)));
    const int row1 = std::min(height_ - 1, static_cast<int>(std::ceil(ymax)) - 1);
    if (row0 > row1) continue;
    const int slot = static_cast<int>(visible_.size());
    bool drawn = false;
    for (int j = row0; j <= row1; ++j) {
      double xl = std::numeric_limits<double>::infinity(), xr = -xl;
      for (int v = 0; v < m; ++v) {
        ScreenVertex p = screen[static_cast<std::size_t>(v)], q = screen[static_cast<std::size_t>((v + 1) % m)];
        if (p.y == q.y) continue;
        if (q.y < p.y || (q.y == p.y && q.x < p.x)) std::swap(p, q);
        if (j < p.y || j >= q.y) continue;
        const double x = p.x + (j - p.y) * (q.x - p.x) / (q.y - p.y);
        xl = std::min(xl, x);
        xr = std::max(xr, x);
      }
      if (!(xl <= xr)) continue;
      const int i0 = std::max(0, static_cast<int>(std::ceil(std::max(xl, -1.0))));
      const int i1 = std::min(width_ - 1, static_cast<int>(std::ceil(std::min(xr, static_cast<double>(width_) + 1.0))) - 1);
      if (i0 > i1) continue;
      float* depth = inv_depth_.data() + static_cast<std::size_t>(j) * width_;
      std::int32_t* slots = slot_.data() + static_cast<std::size_t>(j) * width_;
      const float row_w = vp.b * static_cast<float>(j) + vp.c;
      for (int i = i0; i <= i1; ++i) {
        const float w = vp.a * static_cast<float>(i) + row_w;
        if (w > depth[i]) {
          depth[i] = w;
          slots[i] = slot;
          drawn = true;
        }
      }
    }
    if (drawn) visible_.push_back(vp);
  }
}

void Rasterizer::render(const World& world, const TextureBank& textures, const PinholeView& view,
                        const Eigen::Isometry3d& T_world_cam, int k, std::vector<float>& out) {
  rasterize(world, view, T_world_cam, k);
  detail::SkyFrame sky{};
  const Eigen::Matrix3d R = T_world_cam.rotation();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) sky.r[r * 3 + c] = static_cast<float>(R(r, c));
  sky.fx = static_cast<float>(view.fx * k);
  sky.fy = static_cast<float>(view.fy * k);
  sky.cx = static_cast<float>(k * (view.cx + 0.5) - 0.5);
  sky.cy = static_cast<float>(k * (view.cy + 0.5) - 0.5);
  sky.has_sky = world.has_sky;

  // Resolve (MSAA-like): per output pixel, each distinct polygon among its k x k samples is shaded
  // once, at the mean position of its samples, and weighted by their count.
  out.assign(static_cast<std::size_t>(view.width) * view.height, 0.0f);
  const float pixel = static_cast<float>(k);
  const float norm = 1.0f / static_cast<float>(k * k);
  std::int32_t ids[16];
  float count[16], sum_i[16], sum_j[16];
  for (int y = 0; y < view.height; ++y)
    for (int x = 0; x < view.width; ++x) {
      int distinct = 0;
      for (int sj = 0; sj < k; ++sj) {
        const std::int32_t* row = slot_.data() + static_cast<std::size_t>(y * k + sj) * width_ + x * k;
        for (int si = 0; si < k; ++si) {
          const std::int32_t id = row[si];
          int d = 0;
          while (d < distinct && ids[d] != id) ++d;
          if (d == distinct) ids[distinct] = id, count[distinct] = 0, sum_i[distinct] = 0, sum_j[distinct] = 0, ++distinct;
          count[d] += 1.0f;
          sum_i[d] += static_cast<float>(si);
          sum_j[d] += static_cast<float>(sj);
        }
      }
      float value = 0.0f;
      for (int d = 0; d < distinct; ++d) {
        const float i = static_cast<float>(x * k) + sum_i[d] / count[d], j = static_cast<float>(y * k) + sum_j[d] / count[d];
        const float shade = ids[d] < 0 ? detail::shade_sky(sky, textures, i, j, pixel)
                                       : detail::shade_surface(visible_[static_cast<std::size_t>(ids[d])], textures, i, j, pixel);
        value += count[d] * shade;
      }
      out[static_cast<std::size_t>(y) * view.width + x] = value * norm;
    }
}

std::vector<DepthSample> Rasterizer::depth_map(const World& world, const PinholeView& view, const Eigen::Isometry3d& T_world_cam) {
  rasterize(world, view, T_world_cam, 1);
  std::vector<DepthSample> out(static_cast<std::size_t>(view.width) * view.height);
  for (std::size_t p = 0; p < out.size(); ++p)
    if (slot_[p] >= 0) {
      out[p].depth_m = 1.0f / inv_depth_[p];
      out[p].polygon = visible_[static_cast<std::size_t>(slot_[p])].polygon;
    }
  return out;
}

}  // namespace porta::slam::render
