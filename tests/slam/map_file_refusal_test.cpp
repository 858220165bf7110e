// Map files that must be refused (porta/slam/map_file.hpp): missing, empty, wrong magic, a newer
// version, truncated at every section boundary and inside sections, a flipped byte in every section,
// huge counts and ids and links to absent objects in re-checksummed sections; each error names the
// file and the problem and leaves the target map empty. Also: a non-empty target map, another camera.
#if PORTA_SLAM_BUILT
#include <algorithm>
#include <random>

#include "map_file_scene.hpp"

namespace porta::slam::mapping_test {
namespace {

TEST_F(MapFile, MissingAndEmptyFilesAndFoldersAreRefused) {
  EXPECT_NE(load_error(path("no_such.pmap")).find("cannot open: no such file"), std::string::npos);
  write_bytes(path("empty.pmap"), {});
  EXPECT_NE(load_error(path("empty.pmap")).find("the file is empty"), std::string::npos);
  EXPECT_NE(load_error(dir_.string()).find("it is a directory"), std::string::npos);
  EXPECT_THROW(read_map_info(path("no_such.pmap")), MapFileError);
}

TEST_F(MapFile, WrongMagicIsRefused) {
  write_bytes(path("garbage.pmap"), Bytes{'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd', '!', '\n'});
  EXPECT_NE(load_error(path("garbage.pmap")).find("not a PortaSLAM map file"), std::string::npos);
  Bytes bytes = read_bytes(saved_scene());
  bytes[3] ^= 0x20;
  write_bytes(path("magic.pmap"), bytes);
  EXPECT_NE(load_error(path("magic.pmap")).find("not a PortaSLAM map file"), std::string::npos);
}

TEST_F(MapFile, NewerVersionIsRefused) {
  Bytes bytes = read_bytes(saved_scene());
  bytes[8] = 2;
  write_bytes(path("v2.pmap"), bytes);
  EXPECT_NE(load_error(path("v2.pmap"))
                .find("written by a newer PortaSLAM (format version 2, this program reads 1)"),
            std::string::npos);
}

TEST_F(MapFile, TruncatedAtEverySectionBoundaryIsRefused) {
  const std::string file = saved_scene();
  const Bytes bytes = read_bytes(file);
  const MapFileInfo info = read_map_info(file);
  for (const MapFileSection& s : info.sections) {  // cut just before each section: after its predecessor
    write_bytes(path("cut.pmap"),
                Bytes(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(s.offset)));
    const std::string error = load_error(path("cut.pmap"));
    EXPECT_NE(error.find("truncated: the file ends at offset " + std::to_string(s.offset)), std::string::npos)
        << error;
    EXPECT_NE(error.find("section '" + s.tag + "'"), std::string::npos) << error;
  }
}

TEST_F(MapFile, TruncatedInsideHeadersAndSectionsIsRefused) {
  const std::string file = saved_scene();
  const Bytes bytes = read_bytes(file);
  std::vector<std::size_t> cuts = {4, 8, 11};
  for (const MapFileSection& s : read_map_info(file).sections) {
    for (std::uint64_t at :
         {s.offset + 2, s.offset + 11, s.offset + 12 + s.size / 2, s.offset + 12 + s.size + 3}) {
      cuts.push_back(static_cast<std::size_t>(at));
    }
  }
  for (std::size_t cut : cuts) {
    write_bytes(path("cut.pmap"), Bytes(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(cut)));
    const std::string error = load_error(path("cut.pmap"));
    EXPECT_NE(error.find("truncated"), std::string::npos) << "cut at " << cut << ": " << error;
  }
}

TEST_F(MapFile, AnUnexpectedSectionOrBytesAfterTheEndAreRefused) {
  const std::string file = saved_scene();
  const Bytes bytes = read_bytes(file);
  Bytes renamed = bytes;
  renamed[read_map_info(file).sections[3].offset] = 'X';  // MPNT -> XPNT
  write_bytes(path("renamed.pmap"), renamed);
  std::string error = load_error(path("renamed.pmap"));
  EXPECT_NE(error.find("unexpected section 'XPNT' at offset"), std::string::npos) << error;
  EXPECT_NE(error.find("where section 'MPNT' should be"), std::string::npos) << error;

  Bytes longer = bytes;
  longer.insert(longer.end(), {'m', 'o', 'r', 'e'});
  write_bytes(path("longer.pmap"), longer);
  error = load_error(path("longer.pmap"));
  EXPECT_NE(error.find("4 unexpected bytes after the end section"), std::string::npos) << error;
}

TEST_F(MapFile, FlippedByteInEverySectionFailsTheChecksum) {
  const std::string file = saved_scene();
  const Bytes bytes = read_bytes(file);
  for (const MapFileSection& s : read_map_info(file).sections) {
    ASSERT_GT(s.size, 0u) << s.tag;
    Bytes flipped = bytes;
    flipped[s.offset + 12 + s.size / 2] ^= 0x10;
    write_bytes(path("flipped.pmap"), flipped);
    const std::string error = load_error(path("flipped.pmap"));
    EXPECT_NE(error.find("section '" + s.tag + "'"), std::string::npos) << error;
    EXPECT_NE(error.find("checksum mismatch"), std::string::npos) << error;
  }
}

TEST_F(MapFile, HugeCountsAndIdsInARechecksummedSectionAreRefusedWithoutAllocating) {
  const std::string file = saved_scene();
  const Bytes bytes = read_bytes(file);
  const MapFileInfo info = read_map_info(file);
  const MapFileSection& keyframes = info.sections[2];
  const MapFileSection& points = info.sections[3];
  struct Edit {
    const MapFileSection& section;
    std::size_t payload_offset;
    std::uint64_t value;
    const char* expected;
  };
  const std::vector<Edit> edits = {
      {keyframes, 0, std::uint64_t{1} << 62, "a count of 4611686018427387904 keyframes"},
      {keyframes, 8 + 8 + 8 + 8 + 96, ~std::uint64_t{0} / 3,
       "features of keyframe 0"},  // first keyframe's features
      {points, 8 + 8 + 24 + 32 + 24 + 16 + 24 + 8, std::uint64_t{1} << 40, "observations of map point"},
  };
  for (const Edit& edit : edits) {
    Bytes edited = bytes;
    put_u64(edited, edit.section.offset + 12 + edit.payload_offset, edit.value);
    rechecksum(edited, edit.section);
    write_bytes(path("huge.pmap"), edited);
    const std::string error = load_error(path("huge.pmap"));
    EXPECT_NE(error.find(edit.expected), std::string::npos) << error;
    EXPECT_NE(error.find("bytes are left in the section"), std::string::npos) << error;
  }

  // A keyframe id of 2^40 would need 2^40 slots in the map: refused as implausible.
  Map one;
  {
    std::lock_guard lock(one.mutex);
    one.add_keyframe(Frame(0, 0.0, scene_map().keyframe_by_id(0)->features, kCamera));
  }
  save_map(path("one.pmap"), one, test_settings());
  Bytes single = read_bytes(path("one.pmap"));
  const MapFileSection section = read_map_info(path("one.pmap")).sections[2];
  put_u64(single, section.offset + 12 + 8, std::uint64_t{1} << 40);
  rechecksum(single, section);
  write_bytes(path("huge_id.pmap"), single);
  EXPECT_NE(load_error(path("huge_id.pmap")).find("keyframe id 1099511627776 is implausibly large"),
            std::string::npos);
}

TEST_F(MapFile, RandomEditsOfRechecksummedSectionsAreRefusedOrLoadNeverCrash) {
  const std::string file = saved_scene();
  const Bytes bytes = read_bytes(file);
  const std::vector<MapFileSection> sections = read_map_info(file).sections;
  std::mt19937 rng(11);
  int refused = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const MapFileSection& s = sections[static_cast<std::size_t>(trial) % 4];  // CAMR SETT KFRM MPNT
    Bytes edited = bytes;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      // Half the edits hit the first 256 bytes of the payload: counts, ids and sizes live there.
      const std::size_t span = trial % 2 == 0 ? std::min<std::size_t>(256, s.size) : s.size;
      edited[s.offset + 12 + rng() % span] = static_cast<std::uint8_t>(rng());
    }
    rechecksum(edited, s);
    write_bytes(path("edited.pmap"), edited);
    Map map;
    try {
      load_map(path("edited.pmap"), map);
    } catch (const MapFileError&) {
      ++refused;
    }
  }
  EXPECT_GT(refused, 100);  // most edits break something the loader checks
}

TEST_F(MapFile, LinksToObjectsNotInTheFileAreRefused) {
  const std::string file = saved_scene();
  const Bytes bytes = read_bytes(file);
  const MapFileSection points = read_map_info(file).sections[3];
  const std::size_t first_point = points.offset + 12 + 8;
  const std::size_t reference = first_point + 8 + 24 + 32 + 24 + 16;
  const std::size_t first_feature = first_point + 144 + 8;  // the first observation's feature index

  Bytes edited = bytes;
  put_u64(edited, reference, 77777);
  rechecksum(edited, points);
  write_bytes(path("link.pmap"), edited);
  EXPECT_NE(load_error(path("link.pmap")).find("its reference keyframe 77777 is not in the file"),
            std::string::npos);

  edited = bytes;
  edited[first_feature] = 0xff;
  edited[first_feature + 1] = 0xff;
  rechecksum(edited, points);
  write_bytes(path("feature.pmap"), edited);
  const std::string error = load_error(path("feature.pmap"));
  EXPECT_NE(error.find("is observed by feature 65535 of keyframe"), std::string::npos) << error;
}

TEST_F(MapFile, LoadIntoANonEmptyMapIsRefused) {
  const std::string file = saved_scene();
  Map map;
  load_map(file, map);
  EXPECT_THROW(load_map(file, map), std::invalid_argument);
}

TEST_F(MapFile, CheckMapCameraRefusesAnotherCamera) {
  Map map;
  const MapFileContents contents = load_map(saved_scene(), map);
  EXPECT_NO_THROW(check_map_camera(contents, kCamera, "scene.pmap"));
  StereoCamera half{320, 240, 250.0, 250.0, 160.0, 120.0, 0.1};
  try {
    check_map_camera(contents, half, "scene.pmap");
    FAIL() << "another camera was accepted";
  } catch (const MapFileError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("scene.pmap"), std::string::npos);
    EXPECT_NE(message.find("the map was made with the camera " + kCamera.describe()), std::string::npos)
        << message;
    EXPECT_NE(message.find("this camera is " + half.describe()), std::string::npos) << message;
  }
  StereoCamera shifted = kCamera;
  shifted.cx += 1e-4;  // below the printed precision
  EXPECT_THROW(check_map_camera(contents, shifted, "scene.pmap"), MapFileError);
}

}  // namespace
}  // namespace porta::slam::mapping_test
#endif
