// Map export for viewers (MeshLab, CloudCompare, Open3D, plyfile): the map points and the keyframes'
// camera centres as one coloured point cloud in a binary little-endian PLY 1.0 file, written
// atomically (atomic_file.hpp). Layout (docs/USER_GUIDE.md, "Map export"):
//
//   ply
//   format binary_little_endian 1.0
//   comment PortaSLAM map: <P> map points, then <K> keyframe camera centres (the last K vertices, colour 255
//   0 255) comment colour: <rule> comment frame: the map's world frame (the first camera's: x right, y down,
//   z forward), metres element vertex <P + K> property float x property float y property float z property
//   uchar red property uchar green property uchar blue end_header
//
// then P + K records of 15 bytes (3 float32 little-endian, 3 uint8). Plain `vertex` with x, y, z,
// red, green, blue is what all of those readers take without a question; the comments (which they
// ignore) say which vertices are cameras.
//
// Colours. By height: "up" is -y of the map's world frame (the first camera is y-down; a camera
// held level makes -y the world's up), and a point's height -y goes through a turbo-like ramp
// (height_colour) from the 2nd to the 98th percentile of the map points' heights (clamped beyond),
// so that a few stray far points do not flatten the ramp. By keyframe: the point's first keyframe
// (the keyframe that created it) picks one of 12 distinct colours, keyframe id modulo 12, so that
// the points of neighbouring keyframes differ. Neither rule uses magenta, the cameras' colour.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "porta/slam/map.hpp"

namespace porta::slam {

enum class MapColouring { height, keyframe };

/// "height" or "keyframe"; nullopt for anything else.
std::optional<MapColouring> parse_map_colouring(std::string_view name);
const char* to_string(MapColouring colouring);

/// What is exported: positions in the map's world frame (metres).
struct MapCloud {
  struct Point {
    Eigen::Vector3d position;
    std::uint64_t first_keyframe_id = 0;  ///< the keyframe that created it (it may be culled since)
  };
  std::vector<Point> points;                      ///< good map points, in id order
  std::vector<Eigen::Vector3d> keyframe_centres;  ///< good keyframes' camera centres, in id order
};

/// The good points and keyframes of `map`. The caller holds map.mutex.
MapCloud map_cloud(const Map& map);

using Rgb = std::array<std::uint8_t, 3>;

/// The colour of every keyframe camera centre.
inline constexpr Rgb kKeyframeCentreColour = {255, 0, 255};

/// The keyframe rule: one of 12 distinct colours, `keyframe_id` modulo 12.
Rgb keyframe_colour(std::uint64_t keyframe_id);
/// The height ramp at t in [0, 1] (clamped): blue, cyan, green, yellow, orange, red (Google's "turbo"
/// from 0.1 to 0.9, without its nearly black ends).
Rgb height_colour(double t);

/// The heights (-y, metres) that map to the ends of the ramp: the 2nd and 98th percentiles of the
/// points' heights (by rank: the values at round(0.02 (n - 1)) and round(0.98 (n - 1)) of the sorted
/// heights, so min and max for 25 points or fewer). Both 0 for no points.
struct HeightRange {
  double low_m = 0.0, high_m = 0.0;
};
HeightRange height_range(const MapCloud& cloud);

/// The colour a map point gets under `colouring` (`range` from height_range; a range narrower than
/// 1 mm gives the ramp's middle to every point).
Rgb point_colour(const MapCloud::Point& point, MapColouring colouring, const HeightRange& range);

/// Counts of an export. Points with a non-finite coordinate (none in a healthy map) are left out,
/// so that every vertex of the file is finite; `skipped_non_finite` says how many.
struct MapExportStats {
  std::size_t map_points = 0, keyframe_centres = 0, skipped_non_finite = 0;
  std::size_t header_bytes = 0, file_bytes = 0;
  std::size_t vertices() const { return map_points + keyframe_centres; }
};

/// Bytes of one vertex record: float x, y, z and uchar red, green, blue.
inline constexpr std::size_t kPlyVertexBytes = 15;

/// The PLY header for `map_points` points and `keyframe_centres` cameras (the layout above).
std::string map_ply_header(std::size_t map_points, std::size_t keyframe_centres, MapColouring colouring,
                           const HeightRange& range);

/// The whole PLY file.
std::vector<std::uint8_t> encode_map_ply(const MapCloud& cloud, MapColouring colouring,
                                         MapExportStats* stats = nullptr);

/// Writes encode_map_ply() to `path` atomically (temporary beside it, renamed over it when
/// complete). Throws AtomicWriteError naming the file and the reason; no partial file is left.
MapExportStats write_map_ply(const std::string& path, const MapCloud& cloud, MapColouring colouring);

}  // namespace porta::slam
