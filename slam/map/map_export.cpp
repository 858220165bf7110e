// The map as a coloured PLY point cloud (map_export.hpp has the layout and the colour rules).
#include "porta/slam/map_export.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "binary_io.hpp"
#include "porta/slam/atomic_file.hpp"

namespace porta::slam {

namespace {

// Twelve colours that stay apart on a dark (MeshLab, CloudCompare) and a white (Open3D) background;
// no magenta (the cameras) and no grey.
constexpr std::array<Rgb, 12> kKeyframePalette = {{{230, 25, 75},
                                                   {60, 180, 75},
                                                   {255, 225, 25},
                                                   {0, 130, 200},
                                                   {245, 130, 48},
                                                   {70, 240, 240},
                                                   {210, 245, 60},
                                                   {0, 128, 128},
                                                   {170, 110, 40},
                                                   {128, 0, 0},
                                                   {170, 255, 195},
                                                   {0, 0, 128}}};

double height_of(const Eigen::Vector3d& position) { return -position.y(); }

// A coordinate that is finite as a double can still overflow a float.
bool finite_as_float(const Eigen::Vector3d& p) {
  const Eigen::Vector3f f = p.cast<float>();
  return std::isfinite(f.x()) && std::isfinite(f.y()) && std::isfinite(f.z());
}

std::uint8_t channel(double v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
}

std::string format_m(double value) {
  char text[48];
  std::snprintf(text, sizeof text, "%.3f", value);
  return text;
}

void put_vertex(map_file::ByteWriter& out, const Eigen::Vector3d& position, const Rgb& colour) {
  out.f32(static_cast<float>(position.x()));
  out.f32(static_cast<float>(position.y()));
  out.f32(static_cast<float>(position.z()));
  for (const std::uint8_t c : colour) out.u8(c);
}

}  // namespace

std::optional<MapColouring> parse_map_colouring(std::string_view name) {
  if (name == "height") return MapColouring::height;
  if (name == "keyframe") return MapColouring::keyframe;
  return std::nullopt;
}

const char* to_string(MapColouring colouring) {
  return colouring == MapColouring::height ? "height" : "keyframe";
}

MapCloud map_cloud(const Map& map) {
  MapCloud cloud;
  const std::vector<MapPoint*> points = map.points();
  cloud.points.reserve(points.size());
  for (const MapPoint* p : points) cloud.points.push_back({p->position, p->first_keyframe_id});
  for (const KeyFrame* kf : map.keyframes()) cloud.keyframe_centres.push_back(kf->center());
  return cloud;
}

Rgb keyframe_colour(std::uint64_t keyframe_id) {
  return kKeyframePalette[keyframe_id % kKeyframePalette.size()];
}

// Anton Mikhailov's polynomial fit of the turbo colour map (Google, 2019), between 0.1 and 0.9 of it:
// its ends are nearly black, and points would vanish on a viewer's dark background.
Rgb height_colour(double t) {
  const double x = 0.1 + 0.8 * std::clamp(t, 0.0, 1.0);
  const double r =
      0.13572138 +
      x * (4.61539260 + x * (-42.66032258 + x * (132.13108234 + x * (-152.94239396 + x * 59.28637943))));
  const double g =
      0.09140261 +
      x * (2.19418839 + x * (4.84296658 + x * (-14.18503333 + x * (4.27729857 + x * 2.82956604))));
  const double b =
      0.10667330 +
      x * (12.64194608 + x * (-60.58204836 + x * (110.36276771 + x * (-89.90310912 + x * 27.34824973))));
  return {channel(r), channel(g), channel(b)};
}

HeightRange height_range(const MapCloud& cloud) {
  std::vector<double> heights;
  heights.reserve(cloud.points.size());
  for (const MapCloud::Point& p : cloud.points) {
    if (finite_as_float(p.position)) heights.push_back(height_of(p.position));
  }
  if (heights.empty()) return {};
  const auto at_rank = [&](double fraction) {
    const auto k = static_cast<std::size_t>(std::lround(fraction * static_cast<double>(heights.size() - 1)));
    std::nth_element(heights.begin(), heights.begin() + static_cast<std::ptrdiff_t>(k), heights.end());
    return heights[k];
  };
  HeightRange range;
  range.low_m = at_rank(0.02);
  range.high_m = at_rank(0.98);
  return range;
}

Rgb point_colour(const MapCloud::Point& point, MapColouring colouring, const HeightRange& range) {
  if (colouring == MapColouring::keyframe) return keyframe_colour(point.first_keyframe_id);
  const double span = range.high_m - range.low_m;
  if (!(span >= 1e-3)) return height_colour(0.5);
  return height_colour((height_of(point.position) - range.low_m) / span);
}

std::string map_ply_header(std::size_t map_points, std::size_t keyframe_centres, MapColouring colouring,
                           const HeightRange& range) {
  const std::string rule =
      colouring == MapColouring::height
          ? "height (up = -y; turbo ramp from " + format_m(range.low_m) + " m, blue, to " +
                format_m(range.high_m) + " m, red: the 2nd and 98th percentiles)"
          : std::string("keyframe (the point's first keyframe id modulo 12 picks one of 12 colours)");
  return "ply\n"
         "format binary_little_endian 1.0\n"
         "comment PortaSLAM map: " +
         std::to_string(map_points) + " map points, then " + std::to_string(keyframe_centres) +
         " keyframe camera centres (the last " + std::to_string(keyframe_centres) +
         " vertices, colour 255 0 255)\n"
         "comment colour: " +
         rule +
         "\n"
         "comment frame: the map's world frame (the first camera's: x right, y down, z forward), metres\n"
         "element vertex " +
         std::to_string(map_points + keyframe_centres) +
         "\n"
         "property float x\n"
         "property float y\n"
         "property float z\n"
         "property uchar red\n"
         "property uchar green\n"
         "property uchar blue\n"
         "end_header\n";
}

std::vector<std::uint8_t> encode_map_ply(const MapCloud& cloud, MapColouring colouring,
                                         MapExportStats* stats) {
  MapExportStats counts;
  for (const MapCloud::Point& p : cloud.points) {
    if (finite_as_float(p.position)) {
      ++counts.map_points;
    } else {
      ++counts.skipped_non_finite;
    }
  }
  for (const Eigen::Vector3d& c : cloud.keyframe_centres) {
    if (finite_as_float(c)) {
      ++counts.keyframe_centres;
    } else {
      ++counts.skipped_non_finite;
    }
  }
  const HeightRange range = height_range(cloud);
  const std::string header = map_ply_header(counts.map_points, counts.keyframe_centres, colouring, range);
  map_file::ByteWriter out;
  out.bytes.reserve(header.size() + counts.vertices() * kPlyVertexBytes);
  out.raw(header.data(), header.size());
  for (const MapCloud::Point& p : cloud.points) {
    if (finite_as_float(p.position)) put_vertex(out, p.position, point_colour(p, colouring, range));
  }
  for (const Eigen::Vector3d& c : cloud.keyframe_centres) {
    if (finite_as_float(c)) put_vertex(out, c, kKeyframeCentreColour);
  }
  counts.header_bytes = header.size();
  counts.file_bytes = out.bytes.size();
  if (stats != nullptr) *stats = counts;
  return std::move(out.bytes);
}

MapExportStats write_map_ply(const std::string& path, const MapCloud& cloud, MapColouring colouring) {
  MapExportStats stats;
  const std::vector<std::uint8_t> bytes = encode_map_ply(cloud, colouring, &stats);
  write_file_atomically(path, bytes);
  return stats;
}

}  // namespace porta::slam
