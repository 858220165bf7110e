// Decoding a map file: the framing first (magic, version, every section's size and checksum, the
// end section), so that truncation and corruption are reported as such before any content is
// parsed; then each section's records, every count checked against the bytes left before it is
// allocated for, every value that later code indexes with checked against its range. The links
// between records are checked in map_file.cpp (check_links).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <system_error>
#include <type_traits>

#include "binary_io.hpp"
#include "map_file_records.hpp"

namespace porta::slam::map_file {

namespace {

std::string hex32(std::uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08x", v);
  return text;
}

/// A tag as text, with bytes that are not printable ASCII written as \xNN.
std::string printable_tag(std::span<const std::uint8_t> tag) {
  std::string out;
  for (std::uint8_t c : tag) {
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char text[8];
      std::snprintf(text, sizeof text, "\\x%02x", c);
      out += text;
    }
  }
  return out;
}

std::uint64_t read_u64(std::span<const std::uint8_t> b, std::size_t at) {
  std::uint64_t v = 0;
  for (int k = 0; k < 8; ++k) v |= static_cast<std::uint64_t>(b[at + static_cast<std::size_t>(k)]) << (8 * k);
  return v;
}

std::uint32_t read_u32(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::uint32_t>(b[at]) | static_cast<std::uint32_t>(b[at + 1]) << 8 |
         static_cast<std::uint32_t>(b[at + 2]) << 16 | static_cast<std::uint32_t>(b[at + 3]) << 24;
}

/// Checks the magic, the version and the framing of every section; returns the payloads in order.
std::vector<std::span<const std::uint8_t>> split_sections(std::span<const std::uint8_t> bytes,
                                                          const std::string& path, MapFileData& data) {
  const std::size_t size = bytes.size();
  if (size == 0) fail(path, "the file is empty (0 bytes), not a PortaSLAM map file");
  const std::size_t magic_bytes = std::min(size, kMagic.size());
  if (!std::equal(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(magic_bytes), kMagic.begin())) {
    fail(path, "not a PortaSLAM map file (it does not start with \"PORTAMAP\")");
  }
  if (size < kFileHeaderBytes) {
    fail(path, "truncated: the file ends at offset " + std::to_string(size) + ", inside its 12-byte header");
  }
  data.version = read_u32(bytes, 8);
  if (data.version > kMapFileVersion) {
    fail(path, "written by a newer PortaSLAM (format version " + std::to_string(data.version) +
                   ", this program reads " + std::to_string(kMapFileVersion) + ")");
  }
  if (data.version == 0) fail(path, "format version 0 is not a valid version");

  std::vector<std::span<const std::uint8_t>> payloads;
  std::size_t offset = kFileHeaderBytes;
  std::string previous = "the file header";
  for (std::size_t s = 0; s <= kSectionTags.size(); ++s) {
    const std::string expected = s < kSectionTags.size() ? kSectionTags[s] : kEndTag;
    const std::string where = "section '" + expected + "' (at offset " + std::to_string(offset) + ")";
    if (offset == size) {
      fail(path, "truncated: the file ends at offset " + std::to_string(size) + " after " + previous +
                     ", where " + where + " should begin");
    }
    if (size - offset < kSectionHeaderBytes) {
      fail(path,
           "truncated: the file ends at offset " + std::to_string(size) + " inside the header of " + where);
    }
    const auto tag = bytes.subspan(offset, 4);
    if (!std::equal(tag.begin(), tag.end(), expected.begin())) {
      fail(path, "unexpected section '" + printable_tag(tag) + "' at offset " + std::to_string(offset) +
                     " where section '" + expected + "' should be (corrupt file or not format version 1)");
    }
    const std::uint64_t payload_size = read_u64(bytes, offset + 4);
    const std::size_t payload_at = offset + kSectionHeaderBytes;
    if (payload_size > size - payload_at || size - payload_at - payload_size < kSectionCrcBytes) {
      fail(path, "truncated: " + where + " declares " + std::to_string(payload_size) +
                     " payload bytes and a 4-byte checksum from offset " + std::to_string(payload_at) +
                     ", but the file ends at offset " + std::to_string(size));
    }
    const auto payload = bytes.subspan(payload_at, static_cast<std::size_t>(payload_size));
    const std::uint32_t stored = read_u32(bytes, payload_at + payload.size());
    const std::uint32_t computed = map_file_crc32(payload);
    if (stored != computed) {
      fail(path, "section '" + expected + "' (offset " + std::to_string(offset) + ", " +
                     std::to_string(payload_size) + " bytes): checksum mismatch (stored " + hex32(stored) +
                     ", computed " + hex32(computed) + "): the file is corrupt");
    }
    data.sections.push_back({expected, offset, payload_size});
    payloads.push_back(payload);
    offset = payload_at + payload.size() + kSectionCrcBytes;
    previous = "section '" + expected + "'";
  }
  if (offset != size) {
    fail(path, std::to_string(size - offset) + " unexpected bytes after the end section (from offset " +
                   std::to_string(offset) + ")");
  }
  return payloads;
}

bool finite(double v) { return std::isfinite(v); }

StereoCamera decode_camera(ByteReader& r) {
  StereoCamera c;
  c.width = r.i32();
  c.height = r.i32();
  for (double* v : {&c.fx, &c.fy, &c.cx, &c.cy, &c.baseline_m}) *v = r.f64();
  r.expect_end();
  try {
    c.validate();
  } catch (const std::invalid_argument& e) {
    r.problem(std::string("the saved camera is invalid: ") + e.what());
  }
  return c;
}

/// Reads the (name, type, value) entries; known names fill `s`, unknown ones are skipped (a newer
/// writer's extra settings), missing ones keep their defaults (an older writer's file).
void decode_settings(ByteReader& r, SlamSettings& s) {
  struct Entry {
    SettingType type;
    std::uint64_t bits;
  };
  std::map<std::string, Entry> entries;
  const std::uint32_t count = r.u32();
  for (std::uint32_t i = 0; i < count; ++i) {
    std::string name(r.u8(), '\0');  // at most 255 bytes: no count check needed
    r.raw(name.data(), name.size());
    const auto type = static_cast<SettingType>(r.u8());
    std::uint64_t bits = 0;
    switch (type) {
      case SettingType::int32:
        bits = r.u32();
        break;
      case SettingType::float64:
      case SettingType::uint64:
        bits = r.u64();
        break;
      case SettingType::boolean:
        bits = r.u8();
        break;
      default:
        r.problem("setting '" + name + "' has an unknown type " + std::to_string(static_cast<int>(type)));
    }
    if (!entries.emplace(name, Entry{type, bits}).second) r.problem("setting '" + name + "' appears twice");
  }
  r.expect_end();
  for_each_setting(s, [&](const char* name, auto& field) {
    const auto it = entries.find(name);
    if (it == entries.end()) return;
    using T = std::decay_t<decltype(field)>;
    const SettingType expected = std::is_same_v<T, bool>          ? SettingType::boolean
                                 : std::is_same_v<T, int>         ? SettingType::int32
                                 : std::is_same_v<T, std::size_t> ? SettingType::uint64
                                                                  : SettingType::float64;
    if (it->second.type != expected) r.problem(std::string("setting '") + name + "' has the wrong type");
    if constexpr (std::is_same_v<T, bool>) {
      if (it->second.bits > 1) r.problem(std::string("setting '") + name + "' is not 0 or 1");
      field = it->second.bits == 1;
    } else if constexpr (std::is_same_v<T, int>) {
      field = static_cast<std::int32_t>(static_cast<std::uint32_t>(it->second.bits));
    } else if constexpr (std::is_same_v<T, std::size_t>) {
      field = static_cast<std::size_t>(it->second.bits);
    } else {
      field = std::bit_cast<double>(it->second.bits);
    }
  });
}

/// Reads `n` increasing ids (the writer iterates id-ordered maps: no duplicates).
std::vector<std::uint64_t> decode_ids(ByteReader& r, const std::string& what) {
  std::vector<std::uint64_t> ids(r.count(8, what));
  for (std::size_t i = 0; i < ids.size(); ++i) {
    ids[i] = r.u64();
    if (i > 0 && ids[i] <= ids[i - 1]) r.problem(what + " are not in increasing id order");
  }
  return ids;
}

KeyFrameRecord decode_keyframe(ByteReader& r, const FrontendSettings& frontend) {
  const int levels = frontend.levels;
  KeyFrameRecord k;
  k.id = r.u64();
  const std::string name = "keyframe " + std::to_string(k.id);
  k.frame_id = r.u64();
  k.time_s = r.f64();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) m(row, col) = r.f64();
  }
  const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
  if (!m.allFinite() || !finite(k.time_s) ||
      !((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6)) {
    r.problem(name + " has a non-finite time or pose, or a rotation that is not orthonormal");
  }
  k.T_cw.matrix() = m;
  auto f = std::make_shared<FrameFeatures>();
  const std::size_t n = r.count(kFeatureBytes, "features of " + name);
  f->uv.resize(n);
  f->level.resize(n);
  f->angle_rad.resize(n);
  f->descriptors.resize(n);
  f->u_right.resize(n);
  f->depth_m.resize(n);
  k.point_ids.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float u = r.f32(), v = r.f32();
    f->uv[i] = Eigen::Vector2f(u, v);
    f->level[i] = r.u8();
    f->angle_rad[i] = r.f32();
    r.raw(f->descriptors[i].bytes.data(), f->descriptors[i].bytes.size());
    f->u_right[i] = r.f32();
    f->depth_m[i] = r.f32();
    k.point_ids[i] = r.u64();
    // Bounded positions: the feature grid converts them to cell indices.
    const bool ok = finite(u) && finite(v) && std::abs(u) <= 1e6f && std::abs(v) <= 1e6f &&
                    finite(f->angle_rad[i]) && finite(f->u_right[i]) && finite(f->depth_m[i]);
    if (!ok) r.problem(name + ", feature " + std::to_string(i) + ": a non-finite or out-of-range value");
    if (f->level[i] >= levels) {
      r.problem(name + ", feature " + std::to_string(i) + ": level " + std::to_string(f->level[i]) +
                " but the map's pyramid has " + std::to_string(levels) + " levels");
    }
  }
  const std::uint8_t has_keypoints = r.u8();
  if (has_keypoints > 1) {
    r.problem(name + ": keypoint flag " + std::to_string(has_keypoints) + " is not 0 or 1");
  }
  if (has_keypoints == 1) {
    if (r.left() / 8 < n) {
      r.problem(name + ": its " + std::to_string(n) + " keypoints run past the section's end");
    }
    f->keypoints.resize(n);
    for (Keypoint& kp : f->keypoints) {
      for (std::uint16_t* v : {&kp.x, &kp.y, &kp.response}) {
        const std::uint8_t lo = r.u8();
        *v = static_cast<std::uint16_t>(lo | (r.u8() << 8));
      }
      kp.level = r.u8();
      kp.angle_bin = r.u8();
      // The projection-match kernel indexes the pyramid and the orientation tables with these.
      if (kp.level >= levels || kp.angle_bin >= frontend.orientation_bins) {
        r.problem(name + ": a keypoint on level " + std::to_string(kp.level) + ", orientation bin " +
                  std::to_string(kp.angle_bin) + " (the pyramid has " + std::to_string(levels) + " levels, " +
                  std::to_string(frontend.orientation_bins) + " bins)");
      }
    }
  }
  k.features = std::move(f);
  k.parent = r.u64();
  k.children = decode_ids(r, "children of " + name);
  k.connections.resize(r.count(kConnectionBytes, "covisibility connections of " + name));
  for (std::size_t i = 0; i < k.connections.size(); ++i) {
    k.connections[i].first = r.u64();
    k.connections[i].second = r.i32();
    if (i > 0 && k.connections[i].first <= k.connections[i - 1].first) {
      r.problem("covisibility connections of " + name + " are not in increasing id order");
    }
  }
  k.loop_edges = decode_ids(r, "loop edges of " + name);
  return k;
}

PointRecord decode_point(ByteReader& r) {
  PointRecord p;
  p.id = r.u64();
  for (int i = 0; i < 3; ++i) p.position[i] = r.f64();
  r.raw(p.descriptor.bytes.data(), p.descriptor.bytes.size());
  for (int i = 0; i < 3; ++i) p.normal[i] = r.f64();
  p.min_distance = r.f64();
  p.max_distance = r.f64();
  if (!p.position.allFinite() || !p.normal.allFinite() || !finite(p.min_distance) ||
      !finite(p.max_distance)) {
    r.problem("map point " + std::to_string(p.id) + " has a non-finite position, normal or distance");
  }
  p.reference = r.u64();
  p.first_keyframe_id = r.u64();
  p.first_frame_id = r.u64();
  p.visible = r.i32();
  p.found = r.i32();
  p.observations.resize(r.count(kObservationBytes, "observations of map point " + std::to_string(p.id)));
  for (std::size_t i = 0; i < p.observations.size(); ++i) {
    p.observations[i].first = r.u64();
    p.observations[i].second = r.u32();
    if (i > 0 && p.observations[i].first <= p.observations[i - 1].first) {
      r.problem("observations of map point " + std::to_string(p.id) +
                " are not in increasing keyframe order");
    }
  }
  return p;
}

template <class Record>
void require_increasing_ids(const std::vector<Record>& records, ByteReader& r, const char* what) {
  if (records.size() > 1 && records.back().id <= records[records.size() - 2].id) {
    r.problem(std::string(what) + " " + std::to_string(records.back().id) + " follows " +
              std::to_string(records[records.size() - 2].id) + ": ids must increase");
  }
}

}  // namespace

MapFileData decode_map_file(std::span<const std::uint8_t> bytes, const std::string& path) {
  MapFileData data;
  data.file_size = bytes.size();
  const auto payloads = split_sections(bytes, path, data);
  auto reader = [&](std::size_t s) {
    return ByteReader(payloads[s], path, data.sections[s].tag, data.sections[s].offset + kSectionHeaderBytes);
  };
  ByteReader camera = reader(0);
  data.settings.camera = decode_camera(camera);
  ByteReader settings = reader(1);
  decode_settings(settings, data.settings);
  try {
    data.settings.validate();  // also the camera
  } catch (const std::invalid_argument& e) {
    settings.problem(std::string("the saved settings are invalid: ") + e.what());
  }
  ByteReader keyframes = reader(2);
  data.keyframes.resize(keyframes.count(kKeyFrameMinBytes, "keyframes"));
  for (KeyFrameRecord& k : data.keyframes) k = decode_keyframe(keyframes, data.settings.frontend);
  keyframes.expect_end();
  for (std::size_t i = 1; i < data.keyframes.size(); ++i) {
    if (data.keyframes[i].id <= data.keyframes[i - 1].id) keyframes.problem("keyframe ids do not increase");
  }
  ByteReader points = reader(3);
  data.points.resize(points.count(kPointMinBytes, "map points"));
  for (PointRecord& p : data.points) p = decode_point(points);
  points.expect_end();
  for (std::size_t i = 1; i < data.points.size(); ++i) {
    if (data.points[i].id <= data.points[i - 1].id) points.problem("map point ids do not increase");
  }
  data.place_database.assign(payloads[4].begin(), payloads[4].end());
  ByteReader end = reader(5);
  const std::uint32_t count = end.u32();
  end.expect_end();
  if (count != kSectionTags.size()) {
    end.problem("it counts " + std::to_string(count) + " sections before it, the file has " +
                std::to_string(kSectionTags.size()));
  }
  check_links(data, path);
  return data;
}

MapFileData read_map_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  if (status.type() == fs::file_type::not_found) fail(path, "cannot open: no such file");
  if (error) fail(path, "cannot open: " + error.message());
  if (fs::is_directory(status)) fail(path, "cannot read: it is a directory");
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) fail(path, "cannot open: " + std::error_code(errno, std::generic_category()).message());
  const std::streamoff size = in.tellg();
  if (size < 0) fail(path, "cannot read: the file size is unknown");
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(bytes.data()), size)) fail(path, "cannot read all of its bytes");
  return decode_map_file(bytes, path);
}

}  // namespace porta::slam::map_file
