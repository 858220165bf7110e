// The renderer's static world: planar convex polygons (triangles and quads) with a texture frame,
// in a z-up world frame (metres), kept in a world-fixed 2-D grid for culling. Worlds are generated
// deterministically from a seed and a camera path (street_world.cpp, room_world.cpp): everything
// is a function of (seed, world cell), never of the order in which the path visits a place, so a
// street driven twice is one street.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "porta/slam/render/texture.hpp"

namespace porta::slam::render {

/// Procedural detail drawn on top of a surface's texture from its (u, v) in metres (rasterizer.cpp).
enum class Overlay : int {
  none,
  windows,         ///< façade: a grid of windows with frames, per-window glass brightness
  posters,         ///< room wall: pictures/posters/shelves in some cells of a grid
  ceiling_panels,  ///< ceiling: panel grid and light fittings
  kerb,            ///< a dark line along u = 0 .. 0.15 m (kerb stones, skirting boards)
};

/// How a set of polygons is shaded: value = bias + gain * shade * (texture - mean), then the overlay.
struct Surface {
  Material material = Material::plaster;
  float texels_per_m = 100.0f;  ///< texture density of the detail lookup
  float offset_u = 0.0f, offset_v = 0.0f;  ///< texel offsets (each surface samples its own part)
  float gain = 1.0f;           ///< contrast
  float bias = 128.0f;         ///< brightness
  float shade = 1.0f;          ///< lighting from the surface's orientation
  float second_scale = 0.37f;  ///< the second, rotated lookup that breaks the texture's periodicity
  float second_cos = 0.8f, second_sin = 0.6f;
  Overlay overlay = Overlay::none;
  std::array<float, 4> overlay_params{};  ///< meaning depends on the overlay (see rasterizer.cpp)
  std::uint32_t hash = 0;                 ///< per-surface random bits for overlays
};

/// A planar convex polygon (3 or 4 vertices, in order around it). Texture coordinates in metres:
/// u = (p - origin) . axis_u, v = (p - origin) . axis_v with unit, orthogonal axes in its plane.
struct Polygon {
  std::array<Eigen::Vector3d, 4> vertex{};
  int count = 4;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX(), axis_v = Eigen::Vector3d::UnitY();
  int surface = 0;
};

class World {
 public:
  std::string description;       ///< e.g. "street world: 41234 polygons, 612 buildings, ..."
  std::vector<Polygon> polygons;
  std::vector<Surface> surfaces;
  bool has_sky = false;          ///< rays that hit nothing see the sky (else a dark background)
  double view_range_m = 1e9;     ///< polygons farther than this from the eye are not drawn

  /// Adds a polygon; returns its index.
  int add(const Polygon& polygon);
  /// Adds an axis-aligned or oriented box's faces: centre of the bottom face, half sizes along the
  /// unit horizontal direction `forward` and its left normal, height; `bottom` = add the bottom face.
  void add_box(const Eigen::Vector3d& base_centre, const Eigen::Vector2d& forward, double half_length,
               double half_width, double height, int surface, bool bottom = false);
  /// Builds the culling grid (call after the last add()).
  void build_index(double bin_m = 32.0);
  /// Indices of polygons that may be within `range` of `eye` (horizontally), sorted, no duplicates.
  void collect(const Eigen::Vector3d& eye, double range, std::vector<int>& out) const;

 private:
  double bin_m_ = 32.0;
  Eigen::Vector2d grid_min_ = Eigen::Vector2d::Zero();
  int grid_w_ = 0, grid_h_ = 0;
  double max_radius_ = 0.0;
  std::vector<std::vector<int>> bins_;
};

/// The camera positions a world is built around, in the z-up render frame.
struct PathSamples {
  std::vector<Eigen::Vector3d> positions;
};

/// A street along the path (road, pavements, façades with windows, poles, parked boxes, yards),
/// classified per 2 m world cell by distance to the path; the road surface lies `camera_height_m`
/// below the nearest path point.
World build_street_world(const PathSamples& path, std::uint64_t seed, double camera_height_m = 1.65);

/// A closed room (floor, walls, ceiling, furniture boxes) containing the path with a margin; the
/// floor is at z = 0 when the path stays 0.4 m above it.
World build_room_world(const PathSamples& path, std::uint64_t seed);

/// Room bounds that build_room_world() uses: min and max corners (floor and ceiling in z).
std::pair<Eigen::Vector3d, Eigen::Vector3d> room_bounds(const PathSamples& path);

}  // namespace porta::slam::render
