// World containers: polygons, boxes and the culling grid (world.hpp).
#include <algorithm>
#include <cmath>

#include "porta/slam/render/world.hpp"

namespace porta::slam::render {

int World::add(const Polygon& polygon) {
  polygons.push_back(polygon);
  return static_cast<int>(polygons.size()) - 1;
}

void World::add_box(const Eigen::Vector3d& base_centre, const Eigen::Vector2d& forward, double half_length,
                    double half_width, double height, int surface, bool bottom) {
  const Eigen::Vector3d f(forward.x(), forward.y(), 0.0), l(-forward.y(), forward.x(), 0.0), up(0, 0, 1);
  // Bottom corners counter-clockwise seen from above.
  const std::array<Eigen::Vector3d, 4> c = {base_centre + half_length * f - half_width * l,
                                            base_centre + half_length * f + half_width * l,
                                            base_centre - half_length * f + half_width * l,
                                            base_centre - half_length * f - half_width * l};
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d& a = c[static_cast<std::size_t>(i)];
    const Eigen::Vector3d& b = c[static_cast<std::size_t>((i + 1) % 4)];
    Polygon side;
    side.vertex = {a, b, b + height * up, a + height * up};
    side.origin = a;
    side.axis_u = (b - a).normalized();
    side.axis_v = up;
    side.surface = surface;
    add(side);
  }
  Polygon top;
  top.vertex = {c[0] + height * up, c[1] + height * up, c[2] + height * up, c[3] + height * up};
  top.origin = top.vertex[3];
  top.axis_u = f;
  top.axis_v = l;
  top.surface = surface;
  add(top);
  if (bottom) {
    Polygon base = top;
    base.vertex = {c[0], c[1], c[2], c[3]};
    base.origin = c[3];
    add(base);
  }
}

void World::build_index(double bin_m) {
  bin_m_ = bin_m;
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (const Polygon& p : polygons)
    for (int i = 0; i < p.count; ++i) {
      lo = lo.cwiseMin(p.vertex[static_cast<std::size_t>(i)].head<2>());
      hi = hi.cwiseMax(p.vertex[static_cast<std::size_t>(i)].head<2>());
    }
  if (polygons.empty()) lo = hi = Eigen::Vector2d::Zero();
  grid_min_ = lo;
  grid_w_ = std::max(1, static_cast<int>(std::ceil((hi.x() - lo.x()) / bin_m)) + 1);
  grid_h_ = std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / bin_m)) + 1);
  bins_.assign(static_cast<std::size_t>(grid_w_) * grid_h_, {});
  max_radius_ = 0.0;
  for (std::size_t k = 0; k < polygons.size(); ++k) {
    const Polygon& p = polygons[k];
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (int i = 0; i < p.count; ++i) centre += p.vertex[static_cast<std::size_t>(i)].head<2>();
    centre /= p.count;
    for (int i = 0; i < p.count; ++i)
      max_radius_ = std::max(max_radius_, (p.vertex[static_cast<std::size_t>(i)].head<2>() - centre).norm());
    const int bx = std::clamp(static_cast<int>((centre.x() - lo.x()) / bin_m), 0, grid_w_ - 1);
    const int by = std::clamp(static_cast<int>((centre.y() - lo.y()) / bin_m), 0, grid_h_ - 1);
    bins_[static_cast<std::size_t>(by) * grid_w_ + bx].push_back(static_cast<int>(k));
  }
}

void World::collect(const Eigen::Vector3d& eye, double range, std::vector<int>& out) const {
  out.clear();
  const double reach = range + max_radius_ + 1e-6;
  const auto bin_range = [&](double c, double origin, int n) {
    const int a = static_cast<int>(std::floor((c - reach - origin) / bin_m_));
    const int b = static_cast<int>(std::floor((c + reach - origin) / bin_m_));
    return std::pair<int, int>(std::max(0, a), std::min(n - 1, b));
  };
  const auto [x0, x1] = bin_range(eye.x(), grid_min_.x(), grid_w_);
  const auto [y0, y1] = bin_range(eye.y(), grid_min_.y(), grid_h_);
  for (int by = y0; by <= y1; ++by)
    for (int bx = x0; bx <= x1; ++bx) {
      const double rx0 = grid_min_.x() + bx * bin_m_, ry0 = grid_min_.y() + by * bin_m_;
      const double dx = std::max({rx0 - eye.x(), 0.0, eye.x() - (rx0 + bin_m_)});
      const double dy = std::max({ry0 - eye.y(), 0.0, eye.y() - (ry0 + bin_m_)});
      if (dx * dx + dy * dy > reach * reach) continue;
      const auto& bin = bins_[static_cast<std::size_t>(by) * grid_w_ + bx];
      out.insert(out.end(), bin.begin(), bin.end());
    }
}

}  // namespace porta::slam::render
