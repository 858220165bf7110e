// Map files (DESIGN.md §6): a SLAM map saved to disk with everything needed to continue mapping or
// to localise on it later, in a versioned, checksummed binary format, written atomically.
//
// Format (version 1; docs/ARCHITECTURE.md, "Map files"): the 8 bytes "PORTAMAP", a uint32 format
// version, then sections, each a 4-byte tag, a uint64 payload size, the payload and the CRC-32 of
// the payload: CAMR (the stereo camera), SETT (FrontendSettings and the SlamSettings scalars as
// named entries, so that settings can be added without a format change), KFRM (the good keyframes
// in id order: pose, features, per-feature map point, spanning tree, covisibility, loop edges),
// MPNT (the good map points in id order), PLDB (the caller's place-recognition database, opaque)
// and END! (the number of sections before it, so that a file cut at a section boundary is
// detected). Integers are little-endian, floats and doubles their IEEE bytes: a map loaded and
// saved again gives the same bytes.
//
// What is saved: good objects only. Links to culled objects (a culled parent, an observation by a
// culled keyframe, a feature's culled point) are saved as "none", so a loaded map holds no bad
// objects. Ids are kept (Map::restore_keyframe / restore_point).
#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/slam/map.hpp"
#include "porta/slam/slam_settings.hpp"

namespace porta::slam {

/// A map file that cannot be written or read. what() names the file and the problem
/// ("map file 'run/map.pmap': section 'KFRM' (offset 96, 40213 bytes): checksum mismatch ...").
class MapFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The format version this program writes; it reads files of versions 1 to this one.
inline constexpr std::uint32_t kMapFileVersion = 1;

/// Everything in a map file besides the keyframes and points themselves.
struct MapFileContents {
  /// The settings the map was made with: camera, frontend settings and the SLAM scalars (th_depth,
  /// min_init_stereo_points, ...). Validated on load.
  SlamSettings settings;
  std::vector<std::uint8_t> place_database;  ///< as given to save_map (may be empty)
  std::uint32_t version = 0;                 ///< format version of the file
};

/// Writes `map` (under map.mutex, which it takes itself: the map is copied under the lock, the file
/// written without it) with `settings` and the caller's `place_database` blob. Atomic: a temporary
/// file in the same folder, written, fsync'ed, then renamed over `path`; on any failure the
/// temporary is removed, an existing file at `path` is left untouched, and MapFileError is thrown.
void save_map(const std::string& path, const Map& map, const SlamSettings& settings,
              std::span<const std::uint8_t> place_database = {});

/// Loads the map file at `path` into `map` (under map.mutex). `map` must be empty (Map::empty(),
/// else std::invalid_argument). The whole file is read and checked before `map` is touched, so on a
/// MapFileError `map` is still empty. Errors: a missing, unreadable or empty file, a wrong magic, a
/// newer format version, truncation (names the section and the offsets), a checksum mismatch (names
/// the section) and inconsistent content (a link to an object not in the file, a feature index or
/// level out of range, sizes that disagree, a count larger than the bytes left: counts are checked
/// before anything is allocated).
MapFileContents load_map(const std::string& path, Map& map);

/// One section of a map file as found on disk.
struct MapFileSection {
  std::string tag;           ///< "CAMR", "SETT", "KFRM", "MPNT", "PLDB", "END!"
  std::uint64_t offset = 0;  ///< file offset of the section's tag
  std::uint64_t size = 0;    ///< payload bytes
};

/// What `portaslam map info` prints. Reading it checks the file exactly as load_map does.
struct MapFileInfo {
  std::uint32_t version = 0;
  std::uint64_t file_size = 0;
  std::vector<MapFileSection> sections;
  SlamSettings settings;  ///< camera, pyramid levels and scale factor, ...
  std::size_t keyframes = 0, map_points = 0;
  std::size_t observations = 0;                               ///< (map point, keyframe) pairs
  std::size_t covisibility_edges = 0;                         ///< unordered keyframe pairs
  std::size_t loop_edges = 0;                                 ///< unordered keyframe pairs
  std::uint64_t first_keyframe_id = 0, last_keyframe_id = 0;  ///< 0 when there are none
  double first_time_s = 0.0, last_time_s = 0.0;               ///< keyframe times (0 when none)
  std::size_t place_database_bytes = 0;
};

MapFileInfo read_map_info(const std::string& path);

/// Throws MapFileError when the camera the map was made with differs from `camera` (the dataset's),
/// naming both: "map file 'P' was made with camera 1242x375 fx 718.86 ...; this camera is 621x188 ...".
/// Sizes must be equal, the other values within 1e-9 relative (both come from the same calibration).
void check_map_camera(const MapFileContents& map, const StereoCamera& camera, const std::string& path);

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, as zlib's crc32) of `bytes`: the checksum
/// of every section. Public for tools and tests that edit a file on purpose.
std::uint32_t map_file_crc32(std::span<const std::uint8_t> bytes);

}  // namespace porta::slam
