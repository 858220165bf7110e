// The street world (world.hpp): a world-fixed grid of 2 m cells, each classified by its distance to
// the camera path (road, pavement, building, yard); buildings per 8 m lot (height, material and
// window layout from hash(seed, lot)), poles on the pavement, parked boxes at the road side.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "porta/slam/render/hash.hpp"
#include "porta/slam/render/world.hpp"

namespace porta::slam::render {

namespace {

constexpr double kCell = 2.0;          // ground cell side (m)
constexpr int kLotCells = 4;           // a building lot is 4 x 4 cells (8 m)
constexpr double kRoadHalf = 5.0;      // road: cell centre within this distance of the path
constexpr double kPavementOuter = 10.0;
constexpr double kBuildingOuter = 28.0;
constexpr double kWorldOuter = 46.0;   // nothing farther than this from the path

struct Nearest {
  double distance = std::numeric_limits<double>::infinity();
  double ground_z = 0.0;                          // path height minus the camera height there
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX();  // of the nearest segment
};

// The path as 2-D segments (with ground heights) in a bin grid, for nearest-point queries.
class PathIndex {
 public:
  PathIndex(const std::vector<Eigen::Vector3d>& points, double camera_height) {
    for (const auto& p : points) {
      if (!pts_.empty() && (p.head<2>() - pts_.back().head<2>()).norm() < 0.5) continue;
      pts_.push_back(p - Eigen::Vector3d(0, 0, camera_height));
    }
    if (pts_.size() == 1) pts_.push_back(pts_[0] + Eigen::Vector3d(1e-3, 0, 0));
    lo_ = hi_ = pts_[0].head<2>();
    for (const auto& p : pts_) lo_ = lo_.cwiseMin(p.head<2>()), hi_ = hi_.cwiseMax(p.head<2>());
    w_ = static_cast<int>((hi_.x() - lo_.x()) / kBin) + 1;
    h_ = static_cast<int>((hi_.y() - lo_.y()) / kBin) + 1;
    bins_.assign(static_cast<std::size_t>(w_) * h_, {});
    for (std::size_t s = 0; s + 1 < pts_.size(); ++s) {
      const Eigen::Vector2d a = pts_[s].head<2>().cwiseMin(pts_[s + 1].head<2>()) - lo_;
      const Eigen::Vector2d b = pts_[s].head<2>().cwiseMax(pts_[s + 1].head<2>()) - lo_;
      for (int y = static_cast<int>(a.y() / kBin); y <= std::min(h_ - 1, static_cast<int>(b.y() / kBin)); ++y)
        for (int x = static_cast<int>(a.x() / kBin); x <= std::min(w_ - 1, static_cast<int>(b.x() / kBin)); ++x)
          bins_[static_cast<std::size_t>(y) * w_ + x].push_back(static_cast<int>(s));
    }
  }
  Eigen::Vector2d lo() const { return lo_; }
  Eigen::Vector2d hi() const { return hi_; }

  Nearest nearest(const Eigen::Vector2d& q, double max_distance) const {
    Nearest best;
    const int r = static_cast<int>(std::ceil(max_distance / kBin));
    const int cx = static_cast<int>(std::floor((q.x() - lo_.x()) / kBin));
    const int cy = static_cast<int>(std::floor((q.y() - lo_.y()) / kBin));
    for (int y = std::max(0, cy - r); y <= std::min(h_ - 1, cy + r); ++y)
      for (int x = std::max(0, cx - r); x <= std::min(w_ - 1, cx + r); ++x)
        for (int s : bins_[static_cast<std::size_t>(y) * w_ + x]) {
          const Eigen::Vector2d a = pts_[static_cast<std::size_t>(s)].head<2>();
          const Eigen::Vector2d ab = pts_[static_cast<std::size_t>(s) + 1].head<2>() - a;
          const double len2 = ab.squaredNorm();
          const double t = len2 > 0 ? std::clamp((q - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
          const double d = (a + t * ab - q).norm();
          if (d < best.distance) {  // ties keep the lower segment: bins are visited in a fixed order
            best.distance = d;
            best.ground_z = pts_[static_cast<std::size_t>(s)].z() * (1 - t) + pts_[static_cast<std::size_t>(s) + 1].z() * t;
            best.direction = len2 > 0 ? Eigen::Vector2d(ab / std::sqrt(len2)) : Eigen::Vector2d::UnitX();
          }
        }
    if (best.distance > max_distance) best.distance = std::numeric_limits<double>::infinity();
    return best;
  }

 private:
  static constexpr double kBin = 16.0;
  std::vector<Eigen::Vector3d> pts_;
  Eigen::Vector2d lo_, hi_;
  int w_ = 0, h_ = 0;
  std::vector<std::vector<int>> bins_;
};

enum class CellClass : std::uint8_t { empty, road, pavement, building, yard };

struct Lot {
  bool empty = false;
  double height = 10.0;
  int surface = -1;
  double ground_z = 0.0;
};

float shade_for(const Eigen::Vector3d& normal) {
  const Eigen::Vector3d light = Eigen::Vector3d(0.45, 0.25, 0.86).normalized();
  return static_cast<float>(0.72 + 0.28 * std::abs(normal.dot(light)));
}

}  // namespace

World build_street_world(const PathSamples& path, std::uint64_t seed, double camera_height_m) {
  if (path.positions.empty()) throw std::invalid_argument("street world: empty path");
  const PathIndex index(path.positions, camera_height_m);
  World world;
  world.has_sky = true;
  world.view_range_m = 220.0;

  // Cell grid over the path's box plus the world's reach; cell (i, j) covers [i, i+1) * 2 m.
  const int i0 = static_cast<int>(std::floor((index.lo().x() - kWorldOuter) / kCell));
  const int j0 = static_cast<int>(std::floor((index.lo().y() - kWorldOuter) / kCell));
  const int i1 = static_cast<int>(std::ceil((index.hi().x() + kWorldOuter) / kCell));
  const int j1 = static_cast<int>(std::ceil((index.hi().y() + kWorldOuter) / kCell));
  const long long cells = static_cast<long long>(i1 - i0) * (j1 - j0);
  if (cells > 40'000'000)
    throw std::invalid_argument("street world: the path covers more than 160 km^2; render a part of it");
  const int nw = i1 - i0, nh = j1 - j0;
  auto cell_at = [&](int i, int j) { return static_cast<std::size_t>(j - j0) * nw + (i - i0); };

  std::vector<CellClass> cls(static_cast<std::size_t>(cells), CellClass::empty);
  std::vector<Nearest> near(static_cast<std::size_t>(cells));
  for (int j = j0; j < j1; ++j)
    for (int i = i0; i < i1; ++i) {
      const Nearest n = index.nearest({(i + 0.5) * kCell, (j + 0.5) * kCell}, kWorldOuter);
      near[cell_at(i, j)] = n;
      CellClass c = CellClass::empty;
      if (n.distance < kRoadHalf) c = CellClass::road;
      else if (n.distance < kPavementOuter) c = CellClass::pavement;
      else if (n.distance < kBuildingOuter) c = CellClass::building;
      else if (n.distance < kWorldOuter) c = CellClass::yard;
      cls[cell_at(i, j)] = c;
    }
  // Ground heights at cell corners: the nearest path point's road height.
  std::vector<double> corner_z(static_cast<std::size_t>(nw + 1) * (nh + 1), 0.0);
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      const Nearest n = index.nearest({i * kCell, j * kCell}, kWorldOuter + 4 * kCell);
      corner_z[static_cast<std::size_t>(j - j0) * (nw + 1) + (i - i0)] = std::isfinite(n.distance) ? n.ground_z : 0.0;
    }
  auto corner = [&](int i, int j) {
    return Eigen::Vector3d(i * kCell, j * kCell, corner_z[static_cast<std::size_t>(j - j0) * (nw + 1) + (i - i0)]);
  };

  // Surfaces: one per ground class (world-continuous texture), one per lot, pole, box.
  auto make_surface = [&](Material m, float texels_per_m, std::uint64_t h, float gain, float bias) {
    Surface s;
    s.material = m;
    s.texels_per_m = texels_per_m;
    s.offset_u = static_cast<float>(unit_of(mix64(h)) * 512.0);
    s.offset_v = static_cast<float>(unit_of(mix64(h + 1)) * 512.0);
    s.gain = gain;
    s.bias = bias;
    const double angle = 0.5 + unit_of(mix64(h + 2)) * 1.0;
    s.second_cos = static_cast<float>(std::cos(angle));
    s.second_sin = static_cast<float>(std::sin(angle));
    s.second_scale = static_cast<float>(0.29 + 0.1 * unit_of(mix64(h + 3)));
    s.hash = static_cast<std::uint32_t>(h >> 32);
    world.surfaces.push_back(s);
    return static_cast<int>(world.surfaces.size()) - 1;
  };
  const int road = make_surface(Material::asphalt, 90.0f, hash_of(seed, 1), 1.0f, 100.0f);
  const int pavement = make_surface(Material::paving, 110.0f, hash_of(seed, 2), 1.0f, 145.0f);
  const int yard_grass = make_surface(Material::grass, 100.0f, hash_of(seed, 3), 1.0f, 95.0f);
  const int yard_concrete = make_surface(Material::concrete, 80.0f, hash_of(seed, 4), 0.9f, 125.0f);

  int buildings = 0, poles = 0, boxes = 0;
  std::map<std::pair<int, int>, Lot> lots;
  auto lot_of = [&](int i, int j) -> Lot& {
    const int li = static_cast<int>(std::floor(static_cast<double>(i) / kLotCells));
    const int lj = static_cast<int>(std::floor(static_cast<double>(j) / kLotCells));
    auto [it, inserted] = lots.try_emplace({li, lj});
    Lot& lot = it->second;
    if (inserted) {
      const std::uint64_t h = hash_of(seed, li, lj, 0xB1D);
      HashRng rng(h);
      lot.empty = rng.uniform() < 0.12;
      const int floors = 3 + rng.below(6);
      lot.height = floors * 3.2 + rng.uniform(0.3, 1.5);
      const Nearest n = index.nearest({(li + 0.5) * kLotCells * kCell, (lj + 0.5) * kLotCells * kCell}, 80.0);
      lot.ground_z = std::isfinite(n.distance) ? n.ground_z : 0.0;
      const Material m = std::array{Material::brick, Material::plaster, Material::concrete, Material::plaster}[static_cast<std::size_t>(rng.below(4))];
      // One draw per statement: the order of a call's arguments is unspecified (GCC evaluates them
      // last-first on x86-64, first-first on aarch64), and the world must be the same on every CPU.
      // This is x86-64's order, so that worlds rendered before stay the same.
      const auto param_c = static_cast<float>(rng.uniform(95, 170));
      const auto param_b = static_cast<float>(rng.uniform(0.8, 1.3));
      const auto param_a = static_cast<float>(rng.uniform(70, 120));
      lot.surface = make_surface(m, param_a, h, param_b, param_c);
      Surface& s = world.surfaces[static_cast<std::size_t>(lot.surface)];
      s.overlay = Overlay::windows;
      s.overlay_params = {static_cast<float>(rng.uniform(2.2, 3.6)),    // window spacing along u (m)
                          static_cast<float>(rng.uniform(0.35, 0.6)),   // window width / spacing
                          static_cast<float>(rng.uniform(0.4, 0.6)),    // window height / floor
                          static_cast<float>(rng.uniform(-60, 60))};    // glass brightness shift
      ++buildings;
    }
    return lot;
  };
  auto is_building = [&](int i, int j) {
    if (i < i0 || j < j0 || i >= i1 || j >= j1) return false;
    return cls[cell_at(i, j)] == CellClass::building && !lot_of(i, j).empty;
  };

  for (int j = j0; j < j1; ++j)
    for (int i = i0; i < i1; ++i) {
      const CellClass c = cls[cell_at(i, j)];
      if (c == CellClass::empty) continue;
      if (c == CellClass::building && is_building(i, j)) {
        const Lot& lot = lot_of(i, j);
        const double top = lot.ground_z + lot.height;
        const double base = std::min({corner(i, j).z(), corner(i + 1, j).z(), corner(i, j + 1).z(), corner(i + 1, j + 1).z()}) - 2.5;
        // Side faces towards lower or absent neighbours: (di, dj) = outward direction.
        const std::array<std::array<int, 2>, 4> sides = {{{1, 0}, {-1, 0}, {0, 1}, {0, -1}}};
        for (const auto& d : sides) {
          double from = base;
          if (is_building(i + d[0], j + d[1])) {
            const Lot& other = lot_of(i + d[0], j + d[1]);
            if (&other == &lot || other.ground_z + other.height >= top) continue;
            from = other.ground_z + other.height;
          }
          Polygon face;
          const double x = d[0] > 0 ? (i + 1) * kCell : i * kCell, y = d[1] > 0 ? (j + 1) * kCell : j * kCell;
          Eigen::Vector3d a, b;
          if (d[0] != 0) a = {x, j * kCell, 0}, b = {x, (j + 1) * kCell, 0};
          else a = {i * kCell, y, 0}, b = {(i + 1) * kCell, y, 0};
          face.vertex = {Eigen::Vector3d(a.x(), a.y(), from), Eigen::Vector3d(b.x(), b.y(), from),
                         Eigen::Vector3d(b.x(), b.y(), top), Eigen::Vector3d(a.x(), a.y(), top)};
          face.axis_u = d[0] != 0 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
          face.axis_v = Eigen::Vector3d::UnitZ();
          face.origin = Eigen::Vector3d(0, 0, lot.ground_z);
          // Faces of one lot share a surface; shading differs per orientation, so give each
          // orientation its own copy of the lot's surface.
          Surface oriented = world.surfaces[static_cast<std::size_t>(lot.surface)];
          oriented.shade = shade_for(Eigen::Vector3d(d[0], d[1], 0));
          world.surfaces.push_back(oriented);
          face.surface = static_cast<int>(world.surfaces.size()) - 1;
          world.add(face);
        }
        Polygon roof;
        roof.vertex = {Eigen::Vector3d(i * kCell, j * kCell, top), Eigen::Vector3d((i + 1) * kCell, j * kCell, top),
                       Eigen::Vector3d((i + 1) * kCell, (j + 1) * kCell, top), Eigen::Vector3d(i * kCell, (j + 1) * kCell, top)};
        roof.surface = yard_concrete;
        world.add(roof);
        continue;
      }
      int surface = road;
      if (c == CellClass::pavement) surface = pavement;
      if (c == CellClass::yard || c == CellClass::building)
        surface = (hash_of(seed, i / 8, j / 8, 0x9A2D) & 1) ? yard_grass : yard_concrete;
      Polygon t1, t2;
      t1.count = t2.count = 3;
      t1.vertex = {corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), Eigen::Vector3d::Zero()};
      t2.vertex = {corner(i, j), corner(i + 1, j + 1), corner(i, j + 1), Eigen::Vector3d::Zero()};
      t1.surface = t2.surface = surface;  // texture frame: world x, y (continuous over cells)
      world.add(t1);
      world.add(t2);

      const Nearest& n = near[cell_at(i, j)];
      const std::uint64_t h = hash_of(seed, i, j, 0x5EED);
      const Eigen::Vector3d centre((i + 0.5) * kCell, (j + 0.5) * kCell, n.ground_z);
      if (c == CellClass::pavement && n.distance > 5.6 && n.distance < 7.4 && h % 11 == 0) {
        const int pole = make_surface(Material::concrete, 200.0f, h, 0.8f, static_cast<float>(60 + (h >> 40) % 120));
        world.add_box(centre - Eigen::Vector3d(0, 0, 0.3), n.direction, 0.09, 0.09, 5.3 + (h >> 50) % 3, pole);
        world.add_box(centre + Eigen::Vector3d(0, 0, 5.0 + (h >> 50) % 3), n.direction, 0.25, 0.25, 0.3, pole);
        ++poles;
      } else if (c == CellClass::road && n.distance > 3.8 && n.distance < 4.8 && i % 3 == 0 && j % 3 == 0 && h % 3 == 0) {
        const int body = make_surface(Material::plaster, 150.0f, h, 1.2f, static_cast<float>(40 + (h >> 40) % 180));
        const int cabin = make_surface(Material::patterned, 150.0f, h + 7, 1.0f, 70.0f);
        world.add_box(centre - Eigen::Vector3d(0, 0, 0.1), n.direction, 2.1, 0.85, 1.0, body);
        world.add_box(centre + Eigen::Vector3d(0, 0, 0.9), n.direction, 1.2, 0.75, 0.55, cabin);
        ++boxes;
      } else if (c == CellClass::pavement && n.distance > 8.0 && i % 2 == 0 && j % 2 == 0 && h % 7 == 1) {
        const int crate = make_surface(Material::patterned, 160.0f, h, 1.0f, static_cast<float>(60 + (h >> 40) % 140));
        const double size = 0.3 + 0.3 * unit_of(h);
        world.add_box(centre - Eigen::Vector3d(0, 0, 0.1), n.direction, size, size, 0.6 + size, crate);
        ++boxes;
      }
    }
  world.build_index(32.0);
  world.description = "street world: " + std::to_string(world.polygons.size()) + " polygons, " +
                      std::to_string(buildings) + " building lots, " + std::to_string(poles) + " poles, " +
                      std::to_string(boxes) + " boxes";
  return world;
}

}  // namespace porta::slam::render
