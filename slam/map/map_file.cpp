// load_map, read_map_info, check_map_camera, the CRC-32 and the check of the links between records.
// Decoding is in map_file_reader.cpp, encoding and the atomic write in map_file_writer.cpp.
#include "porta/slam/map_file.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>
#include <set>

#include "binary_io.hpp"
#include "map_file_records.hpp"

namespace porta::slam {

namespace {

constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1u) != 0 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[n] = c;
  }
  return table;
}

constexpr std::array<std::uint32_t, 256> kCrcTable = make_crc_table();

using map_file::KeyFrameRecord;
using map_file::kNoId;
using map_file::MapFileData;
using map_file::PointRecord;

/// The record with `id` in an id-sorted vector, or nullptr.
template <class Record>
const Record* find_record(const std::vector<Record>& records, std::uint64_t id) {
  const auto it = std::lower_bound(records.begin(), records.end(), id,
                                   [](const Record& r, std::uint64_t v) { return r.id < v; });
  return it != records.end() && it->id == id ? &*it : nullptr;
}

template <class Record>
void check_id_bound(const std::vector<Record>& records, const char* what, const char* section,
                    const std::string& path) {
  if (records.empty()) return;
  const std::uint64_t bound = records.size() * map_file::kIdSlotsPerRecord + map_file::kIdSlotAllowance;
  if (records.back().id > bound) {
    map_file::fail(path, std::string("section '") + section + "': " + what + " id " +
                             std::to_string(records.back().id) + " is implausibly large (the file holds " +
                             std::to_string(records.size()) + ", so ids up to " + std::to_string(bound) +
                             " are accepted)");
  }
}

}  // namespace

std::uint32_t map_file_crc32(std::span<const std::uint8_t> bytes) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::uint8_t b : bytes) c = kCrcTable[(c ^ b) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

namespace map_file {

void check_links(const MapFileData& data, const std::string& path) {
  check_id_bound(data.keyframes, "keyframe", "KFRM", path);
  check_id_bound(data.points, "map point", "MPNT", path);
  for (const KeyFrameRecord& k : data.keyframes) {
    const std::string name = "section 'KFRM': keyframe " + std::to_string(k.id);
    for (std::size_t i = 0; i < k.point_ids.size(); ++i) {
      if (k.point_ids[i] != kNoId && find_record(data.points, k.point_ids[i]) == nullptr) {
        fail(path, name + ", feature " + std::to_string(i) + ": map point " + std::to_string(k.point_ids[i]) +
                       " is not in the file");
      }
    }
    auto check_keyframe = [&](std::uint64_t id, const char* link) {
      if (id == k.id) fail(path, name + ": its " + link + " is itself");
      if (find_record(data.keyframes, id) == nullptr) {
        fail(path, name + ": its " + link + " " + std::to_string(id) + " is not in the file");
      }
    };
    if (k.parent != kNoId) check_keyframe(k.parent, "parent");
    for (std::uint64_t id : k.children) check_keyframe(id, "child");
    for (const auto& [id, weight] : k.connections) check_keyframe(id, "covisible keyframe");
    for (std::uint64_t id : k.loop_edges) check_keyframe(id, "loop edge");
  }
  for (const PointRecord& p : data.points) {
    const std::string name = "section 'MPNT': map point " + std::to_string(p.id);
    if (p.reference != kNoId && find_record(data.keyframes, p.reference) == nullptr) {
      fail(path, name + ": its reference keyframe " + std::to_string(p.reference) + " is not in the file");
    }
    for (const auto& [id, feature] : p.observations) {
      const KeyFrameRecord* k = find_record(data.keyframes, id);
      if (k == nullptr) {
        fail(path, name + " is observed by keyframe " + std::to_string(id) + ", which is not in the file");
      }
      if (feature >= k->features->size()) {
        fail(path, name + " is observed by feature " + std::to_string(feature) + " of keyframe " +
                       std::to_string(id) + ", which has " + std::to_string(k->features->size()) +
                       " features");
      }
    }
  }
}

}  // namespace map_file

namespace {

/// Turns checked records into map objects (the caller holds map.mutex; `map` is empty).
void restore(const MapFileData& data, Map& map) {
  std::vector<KeyFrame*> keyframes;
  keyframes.reserve(data.keyframes.size());
  for (const KeyFrameRecord& r : data.keyframes) {
    Frame frame(r.frame_id, r.time_s, r.features, data.settings.camera);
    frame.T_cw = r.T_cw;
    frame.has_pose = true;
    keyframes.push_back(map.restore_keyframe(r.id, frame));
  }
  auto keyframe = [&](std::uint64_t id) -> KeyFrame* {
    const KeyFrameRecord* r = find_record(data.keyframes, id);
    return r == nullptr ? nullptr : keyframes[static_cast<std::size_t>(r - data.keyframes.data())];
  };
  std::vector<MapPoint*> points;
  points.reserve(data.points.size());
  for (const PointRecord& r : data.points) {
    MapPoint* p =
        map.restore_point(r.id, r.position, keyframe(r.reference), r.first_keyframe_id, r.first_frame_id);
    p->descriptor = r.descriptor;
    p->normal = r.normal;
    p->min_distance = r.min_distance;
    p->max_distance = r.max_distance;
    p->visible = r.visible;
    p->found = r.found;
    for (const auto& [id, feature] : r.observations)
      p->observations[keyframe(id)] = static_cast<int>(feature);
    points.push_back(p);
  }
  for (std::size_t i = 0; i < data.keyframes.size(); ++i) {
    const KeyFrameRecord& r = data.keyframes[i];
    KeyFrame* k = keyframes[i];
    for (std::size_t f = 0; f < r.point_ids.size(); ++f) {
      if (r.point_ids[f] == kNoId) continue;
      const PointRecord* p = find_record(data.points, r.point_ids[f]);
      k->set_point(f, points[static_cast<std::size_t>(p - data.points.data())]);
    }
    k->parent = r.parent == kNoId ? nullptr : keyframe(r.parent);
    for (std::uint64_t id : r.children) k->children[keyframe(id)] = 0;
    for (const auto& [id, weight] : r.connections) k->connections[keyframe(id)] = weight;
    for (std::uint64_t id : r.loop_edges) k->loop_edges[keyframe(id)] = 0;
  }
}

/// Equal within `1e-9` relative: both values come from the same calibration file.
bool close(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max({1.0, std::abs(a), std::abs(b)}); }

}  // namespace

MapFileContents load_map(const std::string& path, Map& map) {
  const auto require_empty = [&] {
    if (!map.empty()) {
      throw std::invalid_argument("load_map('" + path +
                                  "'): the target map is not empty (load into a new Map)");
    }
  };
  {
    std::lock_guard lock(map.mutex);
    require_empty();  // before reading a large file for nothing
  }
  MapFileData data = map_file::read_map_file(path);
  std::lock_guard lock(map.mutex);
  require_empty();
  restore(data, map);
  return MapFileContents{data.settings, std::move(data.place_database), data.version};
}

MapFileInfo read_map_info(const std::string& path) {
  const MapFileData data = map_file::read_map_file(path);
  MapFileInfo info;
  info.version = data.version;
  info.file_size = data.file_size;
  info.sections = data.sections;
  info.settings = data.settings;
  info.keyframes = data.keyframes.size();
  info.map_points = data.points.size();
  for (const PointRecord& p : data.points) info.observations += p.observations.size();
  std::set<std::pair<std::uint64_t, std::uint64_t>> covisible, loops;  // unordered pairs, small id first
  for (const KeyFrameRecord& k : data.keyframes) {
    for (const auto& [id, weight] : k.connections) covisible.emplace(std::min(id, k.id), std::max(id, k.id));
    for (std::uint64_t id : k.loop_edges) loops.emplace(std::min(id, k.id), std::max(id, k.id));
  }
  info.covisibility_edges = covisible.size();
  info.loop_edges = loops.size();
  if (!data.keyframes.empty()) {
    info.first_keyframe_id = data.keyframes.front().id;
    info.last_keyframe_id = data.keyframes.back().id;
    info.first_time_s = info.last_time_s = data.keyframes.front().time_s;
    for (const KeyFrameRecord& k : data.keyframes) {
      info.first_time_s = std::min(info.first_time_s, k.time_s);
      info.last_time_s = std::max(info.last_time_s, k.time_s);
    }
  }
  info.place_database_bytes = data.place_database.size();
  return info;
}

void check_map_camera(const MapFileContents& map, const StereoCamera& camera, const std::string& path) {
  const StereoCamera& saved = map.settings.camera;
  const bool same = saved.width == camera.width && saved.height == camera.height &&
                    close(saved.fx, camera.fx) && close(saved.fy, camera.fy) && close(saved.cx, camera.cx) &&
                    close(saved.cy, camera.cy) && close(saved.baseline_m, camera.baseline_m);
  if (same) return;
  std::string message =
      "the map was made with the camera " + saved.describe() + "; this camera is " + camera.describe();
  if (saved.describe() == camera.describe()) message += " (they differ below the printed precision)";
  map_file::fail(path, message + ": a map can only be used with the camera it was made with");
}

}  // namespace porta::slam
