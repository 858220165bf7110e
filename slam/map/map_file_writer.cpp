// save_map: snapshot under the map's lock, encode, then an atomic write (temporary file in the same
// folder, fsync, rename). The layout written here is the one map_file_reader.cpp reads; both follow
// docs/ARCHITECTURE.md, "Map files".
#include <filesystem>
#include <mutex>
#include <string_view>
#include <type_traits>

#include "binary_io.hpp"
#include "map_file_records.hpp"
#include "porta/slam/atomic_file.hpp"

namespace porta::slam {

namespace map_file {

namespace {

std::uint64_t id_or_none(const KeyFrame* keyframe) {
  return keyframe != nullptr && !keyframe->bad ? keyframe->id : kNoId;
}

KeyFrameRecord snapshot_keyframe(const KeyFrame& kf) {
  KeyFrameRecord r;
  r.id = kf.id;
  r.frame_id = kf.frame_id;
  r.time_s = kf.time_s;
  r.T_cw = kf.T_cw;
  r.features = kf.features;  // immutable once built: safe to encode after the lock is released
  r.point_ids.reserve(kf.points.size());
  for (const MapPoint* point : kf.points) {
    r.point_ids.push_back(point != nullptr && !point->bad ? point->id : kNoId);
  }
  r.parent = id_or_none(kf.parent);
  for (const auto& [child, unused] : kf.children) {
    if (!child->bad) r.children.push_back(child->id);
  }
  for (const auto& [other, weight] : kf.connections) {
    if (!other->bad) r.connections.emplace_back(other->id, weight);
  }
  for (const auto& [other, unused] : kf.loop_edges) {
    if (!other->bad) r.loop_edges.push_back(other->id);
  }
  return r;
}

PointRecord snapshot_point(const MapPoint& p) {
  PointRecord r;
  r.id = p.id;
  r.position = p.position;
  r.descriptor = p.descriptor;
  r.normal = p.normal;
  r.min_distance = p.min_distance;
  r.max_distance = p.max_distance;
  r.reference = id_or_none(p.reference);
  r.first_keyframe_id = p.first_keyframe_id;
  r.first_frame_id = p.first_frame_id;
  r.visible = p.visible;
  r.found = p.found;
  for (const auto& [keyframe, feature] : p.observations) {
    if (!keyframe->bad) r.observations.emplace_back(keyframe->id, static_cast<std::uint32_t>(feature));
  }
  return r;
}

/// Frames each section: tag, size (patched when the payload is done), payload, CRC-32.
class SectionWriter {
 public:
  explicit SectionWriter(ByteWriter& out) : out_(out) {}

  void begin(const char* tag) {
    out_.raw(tag, 4);
    size_at_ = out_.bytes.size();
    out_.u64(0);
    payload_at_ = out_.bytes.size();
  }
  void end() {
    const std::size_t size = out_.bytes.size() - payload_at_;
    out_.patch_u64(size_at_, size);
    out_.u32(map_file_crc32(std::span(out_.bytes).subspan(payload_at_, size)));
    ++sections_;
  }
  std::uint32_t sections() const { return sections_; }

 private:
  ByteWriter& out_;
  std::size_t size_at_ = 0, payload_at_ = 0;
  std::uint32_t sections_ = 0;
};

void encode_camera(ByteWriter& w, const StereoCamera& c) {
  w.i32(c.width);
  w.i32(c.height);
  for (double v : {c.fx, c.fy, c.cx, c.cy, c.baseline_m}) w.f64(v);
}

void encode_settings(ByteWriter& w, const SlamSettings& s) {
  std::uint32_t count = 0;
  for_each_setting(s, [&](const char*, const auto&) { ++count; });
  w.u32(count);
  for_each_setting(s, [&](const char* name, const auto& value) {
    const std::string_view text(name);
    w.u8(static_cast<std::uint8_t>(text.size()));
    w.raw(text.data(), text.size());
    using T = std::decay_t<decltype(value)>;
    if constexpr (std::is_same_v<T, bool>) {
      w.u8(static_cast<std::uint8_t>(SettingType::boolean));
      w.u8(value ? 1 : 0);
    } else if constexpr (std::is_same_v<T, int>) {
      w.u8(static_cast<std::uint8_t>(SettingType::int32));
      w.i32(value);
    } else if constexpr (std::is_same_v<T, std::size_t>) {
      w.u8(static_cast<std::uint8_t>(SettingType::uint64));
      w.u64(value);
    } else {
      static_assert(std::is_same_v<T, double>, "a setting is an int, a size_t, a double or a bool");
      w.u8(static_cast<std::uint8_t>(SettingType::float64));
      w.f64(value);
    }
  });
}

void encode_keyframe(ByteWriter& w, const KeyFrameRecord& r) {
  w.u64(r.id);
  w.u64(r.frame_id);
  w.f64(r.time_s);
  const Eigen::Matrix4d& m = r.T_cw.matrix();
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) w.f64(m(row, col));
  }
  const FrameFeatures& f = *r.features;
  w.u64(f.size());
  for (std::size_t i = 0; i < f.size(); ++i) {
    w.f32(f.uv[i].x());
    w.f32(f.uv[i].y());
    w.u8(f.level[i]);
    w.f32(f.angle_rad[i]);
    w.raw(f.descriptors[i].bytes.data(), f.descriptors[i].bytes.size());
    w.f32(f.u_right[i]);
    w.f32(f.depth_m[i]);
    w.u64(r.point_ids[i]);
  }
  // Keypoints are optional (tracking derives them from uv and level); a set that is not one per
  // feature could not be read back, so it is left out.
  const bool keypoints = !f.keypoints.empty() && f.keypoints.size() == f.size();
  w.u8(keypoints ? 1 : 0);
  for (std::size_t i = 0; keypoints && i < f.size(); ++i) {
    const Keypoint& kp = f.keypoints[i];
    for (std::uint16_t v : {kp.x, kp.y, kp.response}) {
      w.u8(static_cast<std::uint8_t>(v & 0xffu));
      w.u8(static_cast<std::uint8_t>(v >> 8));
    }
    w.u8(kp.level);
    w.u8(kp.angle_bin);
  }
  w.u64(r.parent);
  w.u64(r.children.size());
  for (std::uint64_t id : r.children) w.u64(id);
  w.u64(r.connections.size());
  for (const auto& [id, weight] : r.connections) {
    w.u64(id);
    w.i32(weight);
  }
  w.u64(r.loop_edges.size());
  for (std::uint64_t id : r.loop_edges) w.u64(id);
}

void encode_point(ByteWriter& w, const PointRecord& r) {
  w.u64(r.id);
  for (int k = 0; k < 3; ++k) w.f64(r.position[k]);
  w.raw(r.descriptor.bytes.data(), r.descriptor.bytes.size());
  for (int k = 0; k < 3; ++k) w.f64(r.normal[k]);
  w.f64(r.min_distance);
  w.f64(r.max_distance);
  w.u64(r.reference);
  w.u64(r.first_keyframe_id);
  w.u64(r.first_frame_id);
  w.i32(r.visible);
  w.i32(r.found);
  w.u64(r.observations.size());
  for (const auto& [keyframe, feature] : r.observations) {
    w.u64(keyframe);
    w.u32(feature);
  }
}

}  // namespace

MapFileData snapshot_map(const Map& map) {
  MapFileData data;
  for (const KeyFrame* kf : map.keyframes()) data.keyframes.push_back(snapshot_keyframe(*kf));
  for (const MapPoint* p : map.points()) data.points.push_back(snapshot_point(*p));
  return data;
}

std::vector<std::uint8_t> encode_map_file(const MapFileData& data) {
  ByteWriter w;
  w.raw(kMagic.data(), kMagic.size());
  w.u32(data.version);
  SectionWriter section(w);
  section.begin(kSectionTags[0]);
  encode_camera(w, data.settings.camera);
  section.end();
  section.begin(kSectionTags[1]);
  encode_settings(w, data.settings);
  section.end();
  section.begin(kSectionTags[2]);
  w.u64(data.keyframes.size());
  for (const KeyFrameRecord& r : data.keyframes) encode_keyframe(w, r);
  section.end();
  section.begin(kSectionTags[3]);
  w.u64(data.points.size());
  for (const PointRecord& r : data.points) encode_point(w, r);
  section.end();
  section.begin(kSectionTags[4]);
  w.raw(data.place_database.data(), data.place_database.size());
  section.end();
  const std::uint32_t before_end = section.sections();
  section.begin(kEndTag);
  w.u32(before_end);
  section.end();
  return std::move(w.bytes);
}

}  // namespace map_file

void save_map(const std::string& path, const Map& map, const SlamSettings& settings,
              std::span<const std::uint8_t> place_database) {
  try {
    settings.validate();
  } catch (const std::invalid_argument& e) {  // SettingsError too: a file the loader would refuse
    map_file::fail(path, std::string("cannot save: ") + e.what());
  }
  map_file::MapFileData data;
  {
    std::lock_guard lock(map.mutex);
    data = map_file::snapshot_map(map);
  }
  data.settings = settings;
  data.place_database.assign(place_database.begin(), place_database.end());
  try {
    write_file_atomically(path, map_file::encode_map_file(data));
  } catch (const AtomicWriteError& e) {
    map_file::fail(path, std::string("cannot save: ") + e.what());
  }
}

}  // namespace porta::slam
