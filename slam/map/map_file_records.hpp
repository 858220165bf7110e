// The content of a map file as plain records (ids instead of pointers): the writer snapshots a Map
// into them under its lock and encodes them without it; the reader decodes and checks them
// completely before load_map turns them into map objects. Private to slam/map/.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "porta/slam/map_file.hpp"

namespace porta::slam::map_file {

/// "No object" in an id field (no parent, no map point at a feature, no reference keyframe).
inline constexpr std::uint64_t kNoId = std::numeric_limits<std::uint64_t>::max();

inline constexpr std::array<char, 8> kMagic = {'P', 'O', 'R', 'T', 'A', 'M', 'A', 'P'};
inline constexpr std::size_t kFileHeaderBytes = 12;     // magic + version
inline constexpr std::size_t kSectionHeaderBytes = 12;  // tag + payload size
inline constexpr std::size_t kSectionCrcBytes = 4;
/// The sections of version 1, in file order, then the end section.
inline constexpr std::array<const char*, 5> kSectionTags = {"CAMR", "SETT", "KFRM", "MPNT", "PLDB"};
inline constexpr const char* kEndTag = "END!";

// Smallest encoded sizes, for checking counts against the bytes left (binary_io.hpp).
inline constexpr std::size_t kFeatureBytes =
    2 * 4 + 1 + 4 + 32 + 4 + 4 + 8;  // uv level angle desc u_r depth point
inline constexpr std::size_t kKeyFrameMinBytes = 8 + 8 + 8 + 12 * 8 + 8 + 1 + 8 + 8 + 8 + 8;
inline constexpr std::size_t kPointMinBytes = 8 + 3 * 8 + 32 + 3 * 8 + 2 * 8 + 3 * 8 + 2 * 4 + 8;
inline constexpr std::size_t kObservationBytes = 8 + 4;
inline constexpr std::size_t kConnectionBytes = 8 + 4;

/// Ids index the map's slot vectors (one pointer each), so a file may not name ids far beyond what
/// it holds: at most this many slots per record, plus a fixed allowance. Real maps stay well inside
/// (culling leaves a few ids per surviving point); a corrupt id cannot allocate gigabytes.
inline constexpr std::uint64_t kIdSlotsPerRecord = 256;
inline constexpr std::uint64_t kIdSlotAllowance = std::uint64_t{1} << 20;

struct KeyFrameRecord {
  std::uint64_t id = 0, frame_id = 0;
  double time_s = 0.0;
  SE3 T_cw = SE3::Identity();
  std::shared_ptr<const FrameFeatures> features;
  std::vector<std::uint64_t> point_ids;  ///< per feature, kNoId = none
  std::uint64_t parent = kNoId;
  std::vector<std::uint64_t> children;                              ///< increasing ids
  std::vector<std::pair<std::uint64_t, std::int32_t>> connections;  ///< (id, weight), increasing ids
  std::vector<std::uint64_t> loop_edges;                            ///< increasing ids
};

struct PointRecord {
  std::uint64_t id = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Descriptor descriptor;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double min_distance = 0.0, max_distance = 0.0;
  std::uint64_t reference = kNoId, first_keyframe_id = 0, first_frame_id = 0;
  std::int32_t visible = 0, found = 0;
  std::vector<std::pair<std::uint64_t, std::uint32_t>>
      observations;  ///< (keyframe id, feature), increasing ids
};

/// A whole map file, decoded.
struct MapFileData {
  std::uint32_t version = kMapFileVersion;
  std::uint64_t file_size = 0;
  std::vector<MapFileSection> sections;  ///< filled by the reader
  SlamSettings settings;
  std::vector<KeyFrameRecord> keyframes;  ///< increasing ids
  std::vector<PointRecord> points;        ///< increasing ids
  std::vector<std::uint8_t> place_database;
};

/// Calls `visit(name, field)` for every saved setting, in file order. SETT holds (name, type,
/// value) entries: a setting added later is one more line here and no format change (a file
/// without it loads the default; a reader that does not know a name skips it).
template <class Settings, class Visit>
void for_each_setting(Settings& s, Visit&& visit) {
  auto& f = s.frontend;
  visit("frontend.levels", f.levels);
  visit("frontend.scale_factor", f.scale_factor);
  visit("frontend.fast_threshold", f.fast_threshold);
  visit("frontend.min_arc", f.min_arc);
  visit("frontend.max_arc", f.max_arc);
  visit("frontend.edge", f.edge);
  visit("frontend.cell_width", f.cell_width);
  visit("frontend.cell_height", f.cell_height);
  visit("frontend.pfa", f.pfa);
  visit("frontend.pfa_window", f.pfa_window);
  visit("frontend.orientation_bins", f.orientation_bins);
  visit("frontend.stereo_min_disparity", f.stereo_min_disparity);
  visit("frontend.stereo_max_disparity", f.stereo_max_disparity);
  visit("frontend.stereo_max_hamming", f.stereo_max_hamming);
  visit("th_depth", s.th_depth);
  visit("min_init_stereo_points", s.min_init_stereo_points);
  visit("min_disparity_px", s.min_disparity_px);
  visit("projection_on_backend", s.projection_on_backend);
  visit("min_tracked_inliers", s.min_tracked_inliers);
  visit("max_frames_between_keyframes", s.max_frames_between_keyframes);
  visit("min_frames_between_keyframes", s.min_frames_between_keyframes);
  visit("mapping_thread_idle_priority", s.mapping_thread_idle_priority);
  visit("mapping_yields_to_tracking", s.mapping_yields_to_tracking);
  visit("loop_closing", s.loop_closing);
  visit("global_bundle_adjustment", s.global_bundle_adjustment);
  visit("place_recognition.max_leaf_size", s.place_recognition.max_leaf_size);
  visit("place_recognition.match_distance", s.place_recognition.match_distance);
}

/// SETT entry types (one byte before the value).
enum class SettingType : std::uint8_t { int32 = 1, float64 = 2, boolean = 3, uint64 = 4 };

/// Copies the good objects of `map` into records (the caller holds map.mutex).
MapFileData snapshot_map(const Map& map);
/// The bytes of the whole file.
std::vector<std::uint8_t> encode_map_file(const MapFileData& data);
/// Decodes and checks the whole file (magic, version, framing, checksums, content, cross links).
MapFileData decode_map_file(std::span<const std::uint8_t> bytes, const std::string& path);
/// Checks every id a record names against the records present (map_file.cpp).
void check_links(const MapFileData& data, const std::string& path);
/// Reads the file at `path` and decodes it.
MapFileData read_map_file(const std::string& path);

}  // namespace porta::slam::map_file
