// Shared by the map file tests (map_file_test.cpp, map_file_refusal_test.cpp): a map made by local
// mapping on the synthetic scene with every kind of field a map file holds, a field-by-field dump of
// a map, byte helpers for editing a file on purpose, and a fixture with a fresh folder per test.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "mapping_scene.hpp"
#include "porta/slam/map_file.hpp"

namespace porta::slam::mapping_test {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

/// A map with everything a file holds: local mapping on the synthetic scene (triangulated and
/// culled points, so point ids have gaps; covisibility; the spanning tree), then a culled keyframe
/// (a gap in keyframe ids), a keyframe whose features carry the frontend's keypoints, and a loop
/// edge between it and keyframe 0. A smaller `spec` gives a smaller map with the same kinds of field
/// (the fuzz seeds use one).
inline std::unique_ptr<Map> make_scene_map(const SceneSpec& spec = SceneSpec{}) {
  const SyntheticScene scene{spec};
  auto map = std::make_unique<Map>();
  LocalMapper mapper(test_settings(), *map);
  TrackingStandIn tracking(scene, *map, mapper);
  for (std::size_t k = 0; k < scene.true_T_cw.size(); ++k) {
    tracking.insert(k, scene.true_T_cw[k]);
    mapper.process_all();
  }
  std::lock_guard lock(map->mutex);
  Frame culled(100, 10.0, scene.features[1], kCamera);
  Map::set_bad(map->add_keyframe(culled));

  auto features = std::make_shared<FrameFeatures>(*scene.features[0]);
  for (std::size_t i = 0; i < features->size(); ++i) {
    const double scale = std::pow(1.2, features->level[i]);
    features->keypoints.push_back(Keypoint{static_cast<std::uint16_t>(features->uv[i].x() / scale),
                                           static_cast<std::uint16_t>(features->uv[i].y() / scale),
                                           static_cast<std::uint16_t>(100 + i), features->level[i],
                                           static_cast<std::uint8_t>(i % 32)});
  }
  Frame revisit(101, 10.1, features, kCamera);
  revisit.T_cw = scene.true_T_cw[0];
  KeyFrame* kf0 = map->keyframe_by_id(0);
  KeyFrame* loop = map->add_keyframe(revisit);
  for (std::size_t i = 0; i < kf0->points.size(); ++i) {
    MapPoint* p = kf0->points[i];
    if (p != nullptr && !p->bad) Map::add_observation(p, loop, static_cast<int>(i));
  }
  loop->update_connections();
  kf0->loop_edges[loop] = 0;
  loop->loop_edges[kf0] = 0;
  return map;
}

inline const Map& scene_map() {
  static const std::unique_ptr<Map> map = make_scene_map();
  return *map;
}

/// Every saved field of every good object, floats as exact hex: equal dumps, equal maps. Links to
/// bad objects are left out (the file does not keep them).
inline std::string dump(const Map& map) {
  std::lock_guard lock(map.mutex);
  std::ostringstream o;
  o << std::hexfloat;
  auto id = [](const auto* object) {
    return object != nullptr && !object->bad ? std::to_string(object->id) : "-";
  };
  for (const KeyFrame* k : map.keyframes()) {
    o << "keyframe " << k->id << " frame " << k->frame_id << " t " << k->time_s << " T_cw";
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) o << ' ' << k->T_cw.matrix()(r, c);
    }
    const FrameFeatures& f = *k->features;
    for (std::size_t i = 0; i < f.size(); ++i) {
      o << "\n  feature " << i << ' ' << f.uv[i].x() << ' ' << f.uv[i].y() << " level " << int{f.level[i]}
        << ' ' << f.angle_rad[i] << ' ' << f.u_right[i] << ' ' << f.depth_m[i] << " point "
        << id(k->points[i]) << " d";
      for (std::uint8_t b : f.descriptors[i].bytes) o << ' ' << int{b};
    }
    for (const Keypoint& kp : f.keypoints) {
      o << "\n  keypoint " << kp.x << ' ' << kp.y << ' ' << kp.response << ' ' << int{kp.level} << ' '
        << int{kp.angle_bin};
    }
    o << "\n  parent " << id(k->parent) << " children";
    for (const auto& [child, unused] : k->children) o << ' ' << id(child);
    o << " connections";
    for (const auto& [other, weight] : k->connections) o << ' ' << id(other) << ':' << weight;
    o << " loops";
    for (const auto& [other, unused] : k->loop_edges) o << ' ' << id(other);
    o << '\n';
  }
  for (const MapPoint* p : map.points()) {
    o << "point " << p->id << " at " << p->position.transpose() << " normal " << p->normal.transpose()
      << " range " << p->min_distance << ' ' << p->max_distance << " reference " << id(p->reference)
      << " first " << p->first_keyframe_id << ' ' << p->first_frame_id << " visible " << p->visible
      << " found " << p->found << " observations";
    for (const auto& [keyframe, feature] : p->observations) {
      if (!keyframe->bad) o << ' ' << keyframe->id << ':' << feature;
    }
    o << " d";
    for (std::uint8_t b : p->descriptor.bytes) o << ' ' << int{b};
    o << '\n';
  }
  return o.str();
}

inline Bytes read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), {});
}

inline void write_bytes(const fs::path& path, const Bytes& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

inline void put_u64(Bytes& bytes, std::size_t at, std::uint64_t v) {
  for (int k = 0; k < 8; ++k)
    bytes[at + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(v >> (8 * k));
}

/// Recomputes the checksum of `section` after an edit, so that the edit reaches the content checks.
inline void rechecksum(Bytes& bytes, const MapFileSection& section) {
  const std::size_t payload = section.offset + 12;
  const std::uint32_t crc = map_file_crc32(std::span(bytes).subspan(payload, section.size));
  for (int k = 0; k < 4; ++k)
    bytes[payload + section.size + static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(crc >> (8 * k));
}

inline const Bytes kPlaceDatabase = {1, 2, 3, 4, 5, 250, 0, 7};

class MapFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("porta_map_file_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  /// The scene map saved into this test's folder.
  std::string saved_scene(const std::string& name = "scene.pmap") {
    const std::string file = path(name);
    save_map(file, scene_map(), test_settings(), kPlaceDatabase);
    return file;
  }

  /// The MapFileError that loading `file` throws ("" when it loads); the target map must stay empty.
  static std::string load_error(const std::string& file) {
    Map map;
    try {
      load_map(file, map);
    } catch (const MapFileError& e) {
      EXPECT_TRUE(map.empty()) << "a failed load left objects in the map";
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos)
          << "the message names the file: " << e.what();
      return e.what();
    }
    return "";
  }

  fs::path dir_;
};

}  // namespace porta::slam::mapping_test
