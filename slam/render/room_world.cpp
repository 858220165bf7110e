// The room world (world.hpp): a closed box around the path (floor, four walls, ceiling) with
// furniture boxes along the walls and in the free space, never on the path.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "porta/slam/render/hash.hpp"
#include "porta/slam/render/world.hpp"

namespace porta::slam::render {

namespace {

constexpr double kWallMargin = 1.8;     // horizontal margin between the path's box and the walls (m)
constexpr double kPathClearance = 0.7;  // furniture keeps this far (horizontally) from the path

float shade_for(const Eigen::Vector3d& normal) {
  const Eigen::Vector3d light = Eigen::Vector3d(0.3, 0.5, 0.81).normalized();
  return static_cast<float>(0.75 + 0.25 * std::abs(normal.dot(light)));
}

}  // namespace

std::pair<Eigen::Vector3d, Eigen::Vector3d> room_bounds(const PathSamples& path) {
  if (path.positions.empty()) throw std::invalid_argument("room world: empty path");
  Eigen::Vector3d lo = path.positions[0], hi = path.positions[0];
  for (const auto& p : path.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  Eigen::Vector3d a = lo - Eigen::Vector3d(kWallMargin, kWallMargin, 0), b = hi + Eigen::Vector3d(kWallMargin, kWallMargin, 0);
  a.z() = lo.z() >= 0.4 ? 0.0 : lo.z() - 0.6;  // floor at z = 0 when the path stays above it
  b.z() = std::max(hi.z() + 1.3, a.z() + 3.5);
  return {a, b};
}

World build_room_world(const PathSamples& path, std::uint64_t seed) {
  const auto [lo, hi] = room_bounds(path);
  World world;
  world.has_sky = false;
  // The path, thinned, for clearance checks.
  std::vector<Eigen::Vector3d> probe;
  for (std::size_t k = 0; k < path.positions.size(); k += std::max<std::size_t>(1, path.positions.size() / 4000))
    probe.push_back(path.positions[k]);
  const double path_floor = [&] {
    double z = 1e300;
    for (const auto& p : probe) z = std::min(z, p.z());
    return z;
  }();

  auto make_surface = [&](Material m, float texels_per_m, std::uint64_t h, float gain, float bias, const Eigen::Vector3d& n) {
    Surface s;
    s.material = m;
    s.texels_per_m = texels_per_m;
    s.offset_u = static_cast<float>(unit_of(mix64(h)) * 512.0);
    s.offset_v = static_cast<float>(unit_of(mix64(h + 1)) * 512.0);
    s.gain = gain;
    s.bias = bias;
    s.shade = shade_for(n);
    const double angle = 0.5 + unit_of(mix64(h + 2));
    s.second_cos = static_cast<float>(std::cos(angle));
    s.second_sin = static_cast<float>(std::sin(angle));
    s.second_scale = static_cast<float>(0.29 + 0.1 * unit_of(mix64(h + 3)));
    s.hash = static_cast<std::uint32_t>(h >> 32);
    world.surfaces.push_back(s);
    return static_cast<int>(world.surfaces.size()) - 1;
  };
  auto quad = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v, int surface) {
    Polygon p;
    p.vertex = {o, o + u, o + u + v, o + v};
    p.origin = o;
    p.axis_u = u.normalized();
    p.axis_v = v.normalized();
    p.surface = surface;
    world.add(p);
  };
  const Eigen::Vector3d size = hi - lo;
  const Eigen::Vector3d ex(size.x(), 0, 0), ey(0, size.y(), 0), ez(0, 0, size.z());
  const int floor = make_surface(hash_of(seed, 11) % 2 ? Material::wood : Material::concrete, 160.0f, hash_of(seed, 10),
                                 1.0f, 115.0f, Eigen::Vector3d::UnitZ());
  quad(lo, ex, ey, floor);
  const int ceiling = make_surface(Material::concrete, 140.0f, hash_of(seed, 12), 0.8f, 170.0f, -Eigen::Vector3d::UnitZ());
  world.surfaces[static_cast<std::size_t>(ceiling)].overlay = Overlay::ceiling_panels;
  quad(lo + ez, ex, ey, ceiling);
  // Walls: origin at the floor, u along the wall, v up.
  const std::array<std::array<Eigen::Vector3d, 3>, 4> walls = {{{lo, ex, Eigen::Vector3d::UnitY()},
                                                                {lo + ey, ex, -Eigen::Vector3d::UnitY()},
                                                                {lo, ey, Eigen::Vector3d::UnitX()},
                                                                {lo + ex, ey, -Eigen::Vector3d::UnitX()}}};
  for (std::size_t w = 0; w < walls.size(); ++w) {
    const std::uint64_t h = hash_of(seed, 20, static_cast<int>(w));
    const Material m = std::array{Material::plaster, Material::brick, Material::concrete, Material::patterned}[h % 4];
    const int s = make_surface(m, 150.0f, h, 1.0f, static_cast<float>(110 + (h >> 40) % 60), walls[w][2]);
    world.surfaces[static_cast<std::size_t>(s)].overlay = Overlay::posters;
    world.surfaces[static_cast<std::size_t>(s)].overlay_params = {1.6f, 0.45f, 0.0f, 0.0f};  // cell (m), fill chance
    quad(walls[w][0], walls[w][1], ez, s);
  }

  // Furniture: candidate boxes, kept when clear of the path (or low enough to fly over).
  auto clear_of_path = [&](const Eigen::Vector2d& c, double half_l, double half_w, const Eigen::Vector2d& f, double top) {
    const Eigen::Vector2d l(-f.y(), f.x());
    for (const auto& p : probe) {
      const Eigen::Vector2d d = p.head<2>() - c;
      const double along = std::max(0.0, std::abs(d.dot(f)) - half_l), across = std::max(0.0, std::abs(d.dot(l)) - half_w);
      if (std::hypot(along, across) < kPathClearance && top > p.z() - 0.6) return false;
    }
    return true;
  };
  int boxes = 0;
  auto try_box = [&](const Eigen::Vector2d& c, const Eigen::Vector2d& f, double half_l, double half_w, double height,
                     std::uint64_t h) {
    if (!clear_of_path(c, half_l, half_w, f, lo.z() + height)) {
      height = std::min(height, path_floor - lo.z() - 0.7);  // a low table the path passes over
      if (height < 0.25 || !clear_of_path(c, half_l, half_w, f, lo.z() + height)) return;
    }
    const Material m = std::array{Material::wood, Material::patterned, Material::concrete, Material::plaster}[h % 4];
    const int s = make_surface(m, 220.0f, h, 1.1f, static_cast<float>(50 + (h >> 40) % 170), Eigen::Vector3d(f.x(), f.y(), 0.3));
    world.add_box(Eigen::Vector3d(c.x(), c.y(), lo.z()), f, half_l, half_w, height, s);
    ++boxes;
  };
  // Along the walls: cabinets and shelves every ~1.2 m where the hash says so.
  for (std::size_t w = 0; w < walls.size(); ++w) {
    const Eigen::Vector3d along = walls[w][1].normalized(), inward = walls[w][2];
    const double length = walls[w][1].norm();
    for (int k = 0; k * 1.2 + 0.8 < length; ++k) {
      const std::uint64_t h = hash_of(seed, 30, static_cast<int>(w), k);
      if (h % 3 == 0) continue;
      HashRng rng(h);
      const double half_l = rng.uniform(0.25, 0.55), depth = rng.uniform(0.3, 0.8), height = rng.uniform(0.4, 2.2);
      const Eigen::Vector3d c = walls[w][0] + along * (k * 1.2 + 0.6) + inward * (depth / 2 + 0.02);
      try_box(c.head<2>(), along.head<2>(), half_l, depth / 2, height, h);
    }
  }
  // In the room: crates, tables, stacks.
  const int free_boxes = static_cast<int>(size.x() * size.y() / 5.0);
  for (int k = 0; k < free_boxes; ++k) {
    const std::uint64_t h = hash_of(seed, 40, k);
    HashRng rng(h);
    // One draw per statement: the order of a call's arguments is unspecified (GCC evaluates them
    // last-first on x86-64, first-first on aarch64), and the room must be the same on every CPU.
    // This is x86-64's order, so that rooms rendered before stay the same.
    const double cy = rng.uniform(lo.y() + 0.6, hi.y() - 0.6);
    const double cx = rng.uniform(lo.x() + 0.6, hi.x() - 0.6);
    const double angle = rng.uniform(0, 3.14159265);
    const double height = rng.uniform(0.3, 1.4);
    const double half_w = rng.uniform(0.2, 0.5);
    const double half_l = rng.uniform(0.2, 0.6);
    try_box({cx, cy}, {std::cos(angle), std::sin(angle)}, half_l, half_w, height, h);
  }
  world.build_index(8.0);
  world.description = "room world: " + std::to_string(size.x()).substr(0, 4) + " x " + std::to_string(size.y()).substr(0, 4) +
                      " x " + std::to_string(size.z()).substr(0, 4) + " m, " + std::to_string(boxes) + " furniture boxes, " +
                      std::to_string(world.polygons.size()) + " polygons";
  return world;
}

}  // namespace porta::slam::render
