// Map files (porta/slam/map_file.hpp): a map made by local mapping on a synthetic scene is saved,
// loaded into a new Map and compared field by field, and saved again to the same bytes; the header
// info counts what the file holds; the write is atomic. The Map's restore API keeps ids and leaves
// gaps that the lists skip. Refused files: map_file_refusal_test.cpp.
#if PORTA_SLAM_BUILT
#include <algorithm>

#include "map_file_scene.hpp"

namespace porta::slam::mapping_test {
namespace {

TEST(MapFileCrc, MatchesTheStandardCheckValue) {
  const std::string text = "123456789";
  EXPECT_EQ(map_file_crc32(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size())),
            0xCBF43926u);
  EXPECT_EQ(map_file_crc32({}), 0u);
}

TEST_F(MapFile, SavedMapLoadsBackFieldByField) {
  const std::string file = saved_scene();
  Map loaded;
  const MapFileContents contents = load_map(file, loaded);
  EXPECT_EQ(contents.version, kMapFileVersion);
  EXPECT_EQ(contents.place_database, kPlaceDatabase);
  EXPECT_EQ(contents.settings.camera.describe(), kCamera.describe());
  EXPECT_EQ(loaded.num_keyframes(), scene_map().num_keyframes());
  EXPECT_EQ(loaded.num_points(), scene_map().num_points());
  EXPECT_GT(loaded.num_points(), 100u);
  const std::string original = dump(scene_map());
  EXPECT_NE(original.find("keypoint"), std::string::npos);  // the scene exercises every field
  EXPECT_NE(original.find("loops 0"), std::string::npos);
  EXPECT_EQ(dump(loaded), original);

  std::lock_guard lock(loaded.mutex);
  const KeyFrame* kf0 = loaded.keyframe_by_id(0);
  ASSERT_NE(kf0, nullptr);
  EXPECT_EQ(kf0->parent, nullptr);
  EXPECT_EQ(kf0->loop_edges.size(), 1u);
  EXPECT_FALSE(kf0->connections.empty());
  for (const MapPoint* p : loaded.points()) {  // both directions of every observation are pointers again
    for (const auto& [keyframe, feature] : p->observations)
      EXPECT_EQ(loaded.keyframe_by_id(keyframe->id), keyframe);
  }
}

TEST_F(MapFile, ResavingALoadedMapGivesIdenticalBytes) {
  const std::string file = saved_scene();
  Map loaded;
  const MapFileContents contents = load_map(file, loaded);
  const std::string again = path("again.pmap");
  save_map(again, loaded, contents.settings, contents.place_database);
  EXPECT_EQ(read_bytes(again), read_bytes(file));
}

TEST_F(MapFile, SettingsRoundTripAndALoadedMapContinuesAfterTheLargestIds) {
  SlamSettings settings = test_settings();
  settings.frontend.levels = 6;
  settings.frontend.scale_factor = 1.25;
  settings.frontend.fast_threshold = 17;
  settings.frontend.pfa = false;
  settings.frontend.stereo_max_disparity = 200;
  settings.th_depth = 40.5;
  settings.min_init_stereo_points = 123;
  settings.min_disparity_px = 0.75;
  settings.projection_on_backend = false;
  settings.min_tracked_inliers = 25;
  settings.max_frames_between_keyframes = 7;
  settings.min_frames_between_keyframes = 3;
  settings.mapping_thread_idle_priority = false;
  settings.mapping_yields_to_tracking = false;
  Map map;
  const std::string file = path("settings.pmap");
  {
    std::lock_guard lock(map.mutex);
    KeyFrame* kf = map.add_keyframe(Frame(0, 0.0, scene_map().keyframe_by_id(0)->features, kCamera));
    map.add_point(Eigen::Vector3d(1, 2, 3), kf, 0);
  }
  save_map(file, map, settings);
  Map loaded;
  const MapFileContents c = load_map(file, loaded);
  EXPECT_EQ(c.settings.frontend.levels, 6);
  EXPECT_EQ(c.settings.frontend.scale_factor, 1.25);
  EXPECT_EQ(c.settings.frontend.fast_threshold, 17);
  EXPECT_FALSE(c.settings.frontend.pfa);
  EXPECT_EQ(c.settings.frontend.stereo_max_disparity, 200);
  EXPECT_EQ(c.settings.frontend.cell_width, settings.frontend.cell_width);
  EXPECT_EQ(c.settings.th_depth, 40.5);
  EXPECT_EQ(c.settings.min_init_stereo_points, 123);
  EXPECT_EQ(c.settings.min_disparity_px, 0.75);
  EXPECT_FALSE(c.settings.projection_on_backend);
  EXPECT_EQ(c.settings.min_tracked_inliers, 25);
  EXPECT_EQ(c.settings.max_frames_between_keyframes, 7);
  EXPECT_EQ(c.settings.min_frames_between_keyframes, 3);
  EXPECT_FALSE(c.settings.mapping_thread_idle_priority);
  EXPECT_FALSE(c.settings.mapping_yields_to_tracking);
  EXPECT_TRUE(c.place_database.empty());

  Map scene;
  load_map(saved_scene(), scene);
  std::lock_guard lock(scene.mutex);
  const std::uint64_t last_keyframe = scene.keyframes().back()->id;
  const std::uint64_t last_point = scene.points().back()->id;
  KeyFrame* next = scene.add_keyframe(Frame(500, 50.0, scene_map().keyframe_by_id(0)->features, kCamera));
  EXPECT_EQ(next->id, last_keyframe + 1);
  EXPECT_EQ(scene.add_point(Eigen::Vector3d::Zero(), next, 500)->id, last_point + 1);
}

TEST_F(MapFile, AnUnknownSettingIsSkippedAndAMissingOneKeepsItsDefault) {
  SlamSettings settings = test_settings();
  settings.th_depth = 40.5;
  settings.min_tracked_inliers = 25;
  save_map(path("named.pmap"), Map(), settings);
  Bytes bytes = read_bytes(path("named.pmap"));
  const MapFileSection section = read_map_info(path("named.pmap")).sections[1];
  const std::string name = "th_depth";  // renamed to a setting this program does not know
  const auto at = std::search(bytes.begin(), bytes.end(), name.begin(), name.end());
  ASSERT_NE(at, bytes.end());
  at[0] = 'x';
  rechecksum(bytes, section);
  write_bytes(path("named.pmap"), bytes);
  Map map;
  const MapFileContents contents = load_map(path("named.pmap"), map);
  EXPECT_EQ(contents.settings.th_depth, SlamSettings{}.th_depth);
  EXPECT_EQ(contents.settings.min_tracked_inliers, 25);
}

TEST_F(MapFile, AnEmptyMapRoundTrips) {
  Map empty;
  const std::string file = path("empty_map.pmap");
  save_map(file, empty, test_settings());
  Map loaded;
  load_map(file, loaded);
  EXPECT_EQ(loaded.num_keyframes(), 0u);
  const MapFileInfo info = read_map_info(file);
  EXPECT_EQ(info.keyframes, 0u);
  EXPECT_EQ(info.sections.size(), 6u);
}

TEST_F(MapFile, InfoCountsWhatTheFileHolds) {
  const std::string file = saved_scene();
  const MapFileInfo info = read_map_info(file);
  std::lock_guard lock(scene_map().mutex);
  EXPECT_EQ(info.version, 1u);
  EXPECT_EQ(info.file_size, fs::file_size(file));
  EXPECT_EQ(info.keyframes, scene_map().keyframes().size());
  EXPECT_EQ(info.map_points, scene_map().points().size());
  std::size_t observations = 0;
  for (const MapPoint* p : scene_map().points()) observations += p->observations.size();
  EXPECT_EQ(info.observations, observations);
  EXPECT_GT(info.covisibility_edges, 0u);
  EXPECT_EQ(info.loop_edges, 1u);
  EXPECT_EQ(info.first_time_s, 0.0);
  EXPECT_EQ(info.last_time_s, 10.1);
  EXPECT_EQ(info.last_keyframe_id, 6u);  // 5 scene keyframes, the culled 5, the revisit 6
  EXPECT_EQ(info.place_database_bytes, kPlaceDatabase.size());
  EXPECT_EQ(info.settings.frontend.levels, 8);
  const std::vector<std::string> tags = {"CAMR", "SETT", "KFRM", "MPNT", "PLDB", "END!"};
  ASSERT_EQ(info.sections.size(), tags.size());
  std::uint64_t offset = 12;
  for (std::size_t s = 0; s < tags.size(); ++s) {
    EXPECT_EQ(info.sections[s].tag, tags[s]);
    EXPECT_EQ(info.sections[s].offset, offset);
    offset += 12 + info.sections[s].size + 4;
  }
  EXPECT_EQ(offset, info.file_size);
}

TEST_F(MapFile, SavingIntoAMissingFolderThrowsAndLeavesNothing) {
  const std::string file = path("no_such_folder/map.pmap");
  try {
    save_map(file, scene_map(), test_settings());
    FAIL() << "saving into a missing folder succeeded";
  } catch (const MapFileError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot save"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir_ / "no_such_folder"));
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(MapFile, SavingOverAnExistingFileReplacesItWhole) {
  const std::string file = path("map.pmap");
  write_bytes(file, Bytes(4'000'000, 0xab));  // longer than the map: no old bytes may remain
  save_map(file, scene_map(), test_settings(), kPlaceDatabase);
  const std::string fresh = path("fresh.pmap");
  save_map(fresh, scene_map(), test_settings(), kPlaceDatabase);
  EXPECT_EQ(read_bytes(file), read_bytes(fresh));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 2);  // no temporaries
}

TEST_F(MapFile, AFailedRenameRemovesTheTemporaryAndKeepsTheTarget) {
  fs::create_directories(dir_ / "taken" / "inside");  // rename() cannot replace a non-empty folder
  EXPECT_THROW(save_map(path("taken"), scene_map(), test_settings()), MapFileError);
  EXPECT_TRUE(fs::is_directory(dir_ / "taken" / "inside"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST(MapRestore, RestoredIdsLeaveGapsThatTheListsSkip) {
  Map map;
  std::lock_guard lock(map.mutex);
  EXPECT_TRUE(map.empty());
  const auto features = scene_map().keyframe_by_id(0)->features;
  KeyFrame* kf = map.restore_keyframe(3, Frame(40, 4.0, features, kCamera));
  EXPECT_EQ(kf->id, 3u);
  EXPECT_EQ(kf->frame_id, 40u);
  EXPECT_FALSE(map.empty());
  EXPECT_EQ(map.keyframe_by_id(1), nullptr);
  EXPECT_EQ(map.keyframe_by_id(3), kf);
  EXPECT_EQ(map.num_keyframes(), 1u);
  MapPoint* p = map.restore_point(7, Eigen::Vector3d(1, 2, 3), kf, 2, 35);
  EXPECT_EQ(p->first_keyframe_id, 2u);  // as given, not the reference's id
  EXPECT_EQ(p->first_frame_id, 35u);
  EXPECT_EQ(map.points().size(), 1u);
  EXPECT_THROW(map.restore_keyframe(3, Frame(41, 4.1, features, kCamera)), std::invalid_argument);
  EXPECT_THROW(map.restore_point(7, Eigen::Vector3d::Zero(), nullptr, 0, 0), std::invalid_argument);
  EXPECT_EQ(map.add_keyframe(Frame(42, 4.2, features, kCamera))->id, 4u);
  EXPECT_EQ(map.add_point(Eigen::Vector3d::Zero(), kf, 42)->id, 8u);
  EXPECT_EQ(map.restore_keyframe(1, Frame(43, 4.3, features, kCamera))->id, 1u);  // a gap can be filled
  EXPECT_EQ(map.num_keyframes(), 3u);
}

}  // namespace
}  // namespace porta::slam::mapping_test
#endif
