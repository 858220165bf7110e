// The map as a PLY point cloud (porta/slam/map_export.hpp): the header to the byte, the file size
// (header + 15 bytes per vertex), the values read back, the two colour rules, the keyframe centres
// after the points in magenta, and an atomic write that leaves nothing behind when it fails.
#if PORTA_SLAM_BUILT
#include "porta/slam/map_export.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <string>

#include "porta/slam/atomic_file.hpp"

namespace porta::slam {
namespace {

namespace fs = std::filesystem;

MapCloud cloud_of(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> centres = {}) {
  MapCloud cloud;
  for (std::size_t i = 0; i < points.size(); ++i) cloud.points.push_back({points[i], i});
  cloud.keyframe_centres = std::move(centres);
  return cloud;
}

/// One vertex record read back from the bytes after the header.
struct Vertex {
  float x, y, z;
  Rgb colour;
};

Vertex vertex_at(const std::vector<std::uint8_t>& file, std::size_t header_bytes, std::size_t index) {
  const std::uint8_t* p = file.data() + header_bytes + index * kPlyVertexBytes;
  const auto f32 = [](const std::uint8_t* b) {
    const std::uint32_t bits = static_cast<std::uint32_t>(b[0]) | static_cast<std::uint32_t>(b[1]) << 8 |
                               static_cast<std::uint32_t>(b[2]) << 16 |
                               static_cast<std::uint32_t>(b[3]) << 24;
    return std::bit_cast<float>(bits);
  };
  return {f32(p), f32(p + 4), f32(p + 8), {p[12], p[13], p[14]}};
}

TEST(MapExport, HeaderIsBinaryLittleEndianPly10WithPlainVertexProperties) {
  EXPECT_EQ(
      map_ply_header(3, 2, MapColouring::height, {-1.5, 2.25}),
      "ply\n"
      "format binary_little_endian 1.0\n"
      "comment PortaSLAM map: 3 map points, then 2 keyframe camera centres (the last 2 vertices, colour 255 "
      "0 255)\n"
      "comment colour: height (up = -y; turbo ramp from -1.500 m, blue, to 2.250 m, red: the 2nd and 98th "
      "percentiles)\n"
      "comment frame: the map's world frame (the first camera's: x right, y down, z forward), metres\n"
      "element vertex 5\n"
      "property float x\n"
      "property float y\n"
      "property float z\n"
      "property uchar red\n"
      "property uchar green\n"
      "property uchar blue\n"
      "end_header\n");
  EXPECT_NE(
      map_ply_header(1, 0, MapColouring::keyframe, {})
          .find(
              "comment colour: keyframe (the point's first keyframe id modulo 12 picks one of 12 colours)\n"),
      std::string::npos);
}

TEST(MapExport, FileIsTheHeaderThenFifteenBytesPerVertex) {
  const MapCloud cloud =
      cloud_of({{0, 0, 1}, {1, 2, 3}, {-4, 5, 6}, {7, -8, 9}}, {{0, 0, 0}, {0, 0, 2}, {0.5, 0, 4}});
  MapExportStats stats;
  const std::vector<std::uint8_t> file = encode_map_ply(cloud, MapColouring::keyframe, &stats);
  const std::string header = map_ply_header(4, 3, MapColouring::keyframe, height_range(cloud));
  ASSERT_GE(file.size(), header.size());
  EXPECT_EQ(std::string(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(header.size())), header);
  EXPECT_EQ(file.size(), header.size() + 7 * 15);
  EXPECT_EQ(stats.map_points, 4u);
  EXPECT_EQ(stats.keyframe_centres, 3u);
  EXPECT_EQ(stats.vertices(), 7u);
  EXPECT_EQ(stats.header_bytes, header.size());
  EXPECT_EQ(stats.file_bytes, file.size());
}

TEST(MapExport, ValuesReadBackAsFloatsWithTheCamerasLastInMagenta) {
  const MapCloud cloud = cloud_of({{0.125, -2.5, 10.0}, {-3.75, 1.0, 42.5}}, {{1.0, -0.25, 0.5}});
  MapExportStats stats;
  const std::vector<std::uint8_t> file = encode_map_ply(cloud, MapColouring::keyframe, &stats);
  const Vertex a = vertex_at(file, stats.header_bytes, 0), b = vertex_at(file, stats.header_bytes, 1);
  const Vertex camera = vertex_at(file, stats.header_bytes, 2);
  EXPECT_EQ(a.x, 0.125f);
  EXPECT_EQ(a.y, -2.5f);
  EXPECT_EQ(a.z, 10.0f);
  EXPECT_EQ(b.x, -3.75f);
  EXPECT_EQ(b.z, 42.5f);
  EXPECT_EQ(a.colour, keyframe_colour(0));
  EXPECT_EQ(b.colour, keyframe_colour(1));
  EXPECT_EQ(camera.x, 1.0f);
  EXPECT_EQ(camera.y, -0.25f);
  EXPECT_EQ(camera.z, 0.5f);
  EXPECT_EQ(camera.colour, kKeyframeCentreColour);
  // Positions are rounded to float, not truncated or scaled.
  const MapCloud fine = cloud_of({{0.1, 1.0 / 3.0, 123456.789}});
  const std::vector<std::uint8_t> fine_file = encode_map_ply(fine, MapColouring::height, &stats);
  const Vertex v = vertex_at(fine_file, stats.header_bytes, 0);
  EXPECT_EQ(v.x, 0.1f);
  EXPECT_EQ(v.y, static_cast<float>(1.0 / 3.0));
  EXPECT_EQ(v.z, 123456.789f);
}

TEST(MapExport, KeyframeColourIsTheFirstKeyframeIdModuloTwelveAndNeverTheCameras) {
  std::set<Rgb> distinct;
  for (std::uint64_t id = 0; id < 12; ++id) {
    distinct.insert(keyframe_colour(id));
    EXPECT_EQ(keyframe_colour(id), keyframe_colour(id + 12));
    EXPECT_NE(keyframe_colour(id), kKeyframeCentreColour);
    EXPECT_NE(keyframe_colour(id), keyframe_colour(id + 1)) << "neighbouring keyframes " << id;
  }
  EXPECT_EQ(distinct.size(), 12u);
  MapCloud cloud;
  cloud.points = {{{0, 0, 1}, 5}, {{0, 0, 2}, 5}, {{0, 0, 3}, 17}, {{0, 0, 4}, 6}};
  MapExportStats stats;
  const std::vector<std::uint8_t> file = encode_map_ply(cloud, MapColouring::keyframe, &stats);
  EXPECT_EQ(vertex_at(file, stats.header_bytes, 0).colour, keyframe_colour(5));
  EXPECT_EQ(vertex_at(file, stats.header_bytes, 1).colour, keyframe_colour(5));
  EXPECT_EQ(vertex_at(file, stats.header_bytes, 2).colour, keyframe_colour(5));  // 17 = 5 + 12
  EXPECT_EQ(vertex_at(file, stats.header_bytes, 3).colour, keyframe_colour(6));
}

TEST(MapExport, HeightIsMinusYAndTheRampRunsFromTheLowestToTheHighestPoint) {
  // y down: the point at y = +3 is the lowest, the one at y = -7 the highest.
  const MapCloud cloud = cloud_of({{0, 3, 5}, {0, -2, 5}, {0, -7, 5}});
  const HeightRange range = height_range(cloud);
  EXPECT_DOUBLE_EQ(range.low_m, -3.0);
  EXPECT_DOUBLE_EQ(range.high_m, 7.0);
  MapExportStats stats;
  const std::vector<std::uint8_t> file = encode_map_ply(cloud, MapColouring::height, &stats);
  EXPECT_EQ(vertex_at(file, stats.header_bytes, 0).colour, height_colour(0.0));
  EXPECT_EQ(vertex_at(file, stats.header_bytes, 1).colour, height_colour(0.5));
  EXPECT_EQ(vertex_at(file, stats.header_bytes, 2).colour, height_colour(1.0));
  // The ramp: dark blue at the bottom, red at the top, green in between; clamped outside [0, 1].
  const Rgb low = height_colour(0.0), middle = height_colour(0.5), high = height_colour(1.0);
  EXPECT_GT(low[2], low[0]);
  EXPECT_GT(middle[1], middle[2]);
  EXPECT_GT(high[0], high[2]);
  EXPECT_EQ(height_colour(-1.0), low);
  EXPECT_EQ(height_colour(2.0), high);
  // A flat map gets the ramp's middle.
  EXPECT_EQ(point_colour({{0, 1, 2}, 0}, MapColouring::height, {1.0, 1.0}), height_colour(0.5));
}

TEST(MapExport, HeightRangeIgnoresTheTopAndBottomTwoPercent) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 100; ++i) points.emplace_back(0.0, -0.1 * i, 1.0);  // heights 0 .. 10 m
  points[100] = {0.0, -500.0, 1.0};                                        // one stray point far up
  const HeightRange range = height_range(cloud_of(points));
  EXPECT_DOUBLE_EQ(range.low_m, 0.2);   // rank 2 of 0..100
  EXPECT_DOUBLE_EQ(range.high_m, 9.8);  // rank 98
  EXPECT_EQ(point_colour({points[100], 0}, MapColouring::height, range), height_colour(1.0));
}

TEST(MapExport, NonFinitePositionsAreLeftOutAndCounted) {
  const double inf = std::numeric_limits<double>::infinity();
  const MapCloud cloud =
      cloud_of({{0, 0, 1}, {std::nan(""), 0, 1}, {0, 1e300, 1}, {2, 0, 1}}, {{0, 0, 0}, {inf, 0, 0}});
  MapExportStats stats;
  const std::vector<std::uint8_t> file = encode_map_ply(cloud, MapColouring::height, &stats);
  EXPECT_EQ(stats.map_points, 2u);
  EXPECT_EQ(stats.keyframe_centres, 1u);
  EXPECT_EQ(stats.skipped_non_finite, 3u);  // 1e300 is finite as a double, not as a float
  EXPECT_EQ(file.size(), stats.header_bytes + 3 * 15);
  EXPECT_NE(std::string(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(stats.header_bytes))
                .find("element vertex 3\n"),
            std::string::npos);
  EXPECT_EQ(vertex_at(file, stats.header_bytes, 1).x, 2.0f);
}

TEST(MapExport, ColouringNamesParse) {
  EXPECT_EQ(parse_map_colouring("height"), MapColouring::height);
  EXPECT_EQ(parse_map_colouring("keyframe"), MapColouring::keyframe);
  EXPECT_FALSE(parse_map_colouring("Height"));
  EXPECT_FALSE(parse_map_colouring("rainbow"));
  EXPECT_FALSE(parse_map_colouring(""));
  EXPECT_STREQ(to_string(MapColouring::keyframe), "keyframe");
}

const StereoCamera kCamera{640, 480, 500.0, 500.0, 320.0, 240.0, 0.1};

Frame frame_with_features(std::uint64_t id) {
  auto f = std::make_shared<FrameFeatures>();
  for (int i = 0; i < 4; ++i) {
    f->uv.emplace_back(100.0f + 50.0f * i, 100.0f);
    f->level.push_back(0);
    f->angle_rad.push_back(0.0f);
    f->descriptors.push_back(Descriptor{});
    f->u_right.push_back(-1.0f);
    f->depth_m.push_back(-1.0f);
  }
  return Frame(id, 0.1 * static_cast<double>(id), f, kCamera);
}

TEST(MapExport, CloudHoldsTheGoodPointsWithTheirFirstKeyframeAndTheKeyframeCentres) {
  Map map;
  KeyFrame* a = map.add_keyframe(frame_with_features(0));
  KeyFrame* b = map.add_keyframe(frame_with_features(1));
  b->T_cw = SE3::Identity();
  b->T_cw.translation() = Eigen::Vector3d(0.0, 0.0, -2.0);  // the camera centre at z = 2
  MapPoint* p0 = map.add_point({1, 2, 3}, a, 0);
  MapPoint* culled = map.add_point({4, 5, 6}, a, 0);
  MapPoint* p2 = map.add_point({7, 8, 9}, b, 1);
  Map::set_bad(culled);
  std::lock_guard lock(map.mutex);
  const MapCloud cloud = map_cloud(map);
  ASSERT_EQ(cloud.points.size(), 2u);
  EXPECT_EQ(cloud.points[0].position, p0->position);
  EXPECT_EQ(cloud.points[0].first_keyframe_id, a->id);
  EXPECT_EQ(cloud.points[1].position, p2->position);
  EXPECT_EQ(cloud.points[1].first_keyframe_id, b->id);
  ASSERT_EQ(cloud.keyframe_centres.size(), 2u);
  EXPECT_TRUE(cloud.keyframe_centres[1].isApprox(Eigen::Vector3d(0.0, 0.0, 2.0)));
  EXPECT_EQ(cloud.points.size() + cloud.keyframe_centres.size(), map.num_points() + map.num_keyframes());
}

class MapExportFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("porta_ply_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(MapExportFile, WritesTheEncodedBytes) {
  const MapCloud cloud = cloud_of({{0, 0, 1}, {1, -1, 2}}, {{0, 0, 0}});
  const fs::path file = dir_ / "map.ply";
  const MapExportStats stats = write_map_ply(file.string(), cloud, MapColouring::height);
  std::ifstream in(file, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  EXPECT_EQ(bytes, encode_map_ply(cloud, MapColouring::height));
  EXPECT_EQ(stats.file_bytes, bytes.size());
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);  // no temporary left
}

TEST_F(MapExportFile, AFolderThatDoesNotExistIsAnErrorNamingTheFileAndLeavesNothing) {
  const fs::path file = dir_ / "no_such_folder" / "map.ply";
  try {
    write_map_ply(file.string(), cloud_of({{0, 0, 1}}), MapColouring::height);
    FAIL() << "expected AtomicWriteError";
  } catch (const AtomicWriteError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(file));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 0);
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
