// Place recognition (slam/place): the HBST-style descriptor tree and the keyframe database on
// random descriptors (structure, erase, serialisation, determinism) and on real images
// (../shared/data/oxford-affine: every img1..img3 finds its own set first among all 36 images).
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "porta/frontend.hpp"
#include "porta/registry.hpp"
#include "porta/slam/place_recognition.hpp"
#include "support/data_path.hpp"
#include "support/test_images.hpp"

namespace porta::slam {
namespace {

std::uint64_t splitmix(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

std::vector<Descriptor> random_descriptors(std::size_t n, std::uint64_t seed) {
  std::vector<Descriptor> out(n);
  for (Descriptor& d : out) {
    for (std::size_t i = 0; i < 32; i += 8) {
      const std::uint64_t v = splitmix(seed);
      for (std::size_t k = 0; k < 8; ++k) d.bytes[i + k] = static_cast<std::uint8_t>(v >> (8 * k));
    }
  }
  return out;
}

/// `d` with `flips` distinct random bits inverted.
Descriptor flipped(Descriptor d, int flips, std::uint64_t seed) {
  std::vector<int> bits;
  while (static_cast<int>(bits.size()) < flips) {
    const int b = static_cast<int>(splitmix(seed) % 256);
    if (std::find(bits.begin(), bits.end(), b) == bits.end()) bits.push_back(b);
  }
  for (int b : bits) d.bytes[static_cast<std::size_t>(b / 8)] ^= static_cast<std::uint8_t>(1u << (b % 8));
  return d;
}

TEST(DescriptorTree, StoredDescriptorsAreFoundInTheirLeafAndLeavesStaySmall) {
  DescriptorTree tree(32);
  const std::vector<Descriptor> a = random_descriptors(3000, 1), b = random_descriptors(3000, 2);
  tree.insert(7, a);
  tree.insert(9, b);
  EXPECT_EQ(tree.size(), 6000u);
  // Random bits split evenly: about log2(6000 / 32) = 7.6 levels; far from a degenerate chain.
  EXPECT_GE(tree.depth(), 7);
  EXPECT_LE(tree.depth(), 16);
  for (std::size_t i = 0; i < a.size(); i += 97) {
    const auto& leaf = tree.leaf_of(a[i]);
    EXPECT_LE(leaf.size(), 32u);
    const auto it = std::find_if(leaf.begin(), leaf.end(),
                                 [&](const TreeEntry& e) { return e.keyframe == 7 && e.feature == i; });
    EXPECT_NE(it, leaf.end()) << "descriptor " << i;
  }
}

TEST(DescriptorTree, EraseRemovesExactlyOneKeyframesEntries) {
  DescriptorTree tree(16);
  const std::vector<Descriptor> a = random_descriptors(500, 3), b = random_descriptors(500, 4);
  tree.insert(1, a);
  tree.insert(2, b);
  tree.erase(1, a);
  EXPECT_EQ(tree.size(), 500u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (const TreeEntry& e : tree.leaf_of(a[i])) EXPECT_NE(e.keyframe, 1u);
  }
  for (std::size_t i = 0; i < b.size(); i += 13) {
    const auto& leaf = tree.leaf_of(b[i]);
    EXPECT_TRUE(std::any_of(leaf.begin(), leaf.end(), [&](const TreeEntry& e) { return e.feature == i; }));
  }
}

TEST(PlaceDatabase, NoisyCopiesOfAKeyframeVoteForItFarAboveChance) {
  PlaceDatabase database;
  for (std::uint64_t k = 0; k < 40; ++k) database.add(k, random_descriptors(800, 100 + k));
  // Keyframe 17 seen again: each descriptor with 10 of 256 bits changed (a good ORB match).
  const std::vector<Descriptor> original = random_descriptors(800, 117);
  std::vector<Descriptor> query;
  for (std::size_t i = 0; i < original.size(); ++i) query.push_back(flipped(original[i], 10, i));
  const std::vector<PlaceScore> scores = database.query(query);
  ASSERT_FALSE(scores.empty());
  EXPECT_EQ(scores.front().keyframe, 17u);
  // About 0.96^depth of the copies reach their leaf (depth ~9 here): most do.
  EXPECT_GT(scores.front().score, 0.4);
  // Random descriptors are ~128 bits apart: within 45 bits by chance almost never.
  if (scores.size() > 1) {
    EXPECT_LT(scores[1].matched, 5);
  }
  // Excluded keyframes are left out.
  const std::vector<std::uint64_t> exclude = {17};
  const std::vector<PlaceScore> others = database.query(query, exclude);
  for (const PlaceScore& s : others) EXPECT_NE(s.keyframe, 17u);
}

TEST(PlaceDatabase, SerialisedDatabaseReadsBackToTheSameBytesAndAnswers) {
  PlaceDatabase database;
  for (std::uint64_t k = 0; k < 10; ++k) database.add(3 * k, random_descriptors(300, 50 + k));
  database.erase(6, random_descriptors(300, 52));
  const std::vector<std::uint8_t> bytes = database.serialize();
  const PlaceDatabase loaded = PlaceDatabase::deserialize(bytes);
  EXPECT_EQ(loaded.serialize(), bytes);
  EXPECT_EQ(loaded.keyframes(), 9u);
  EXPECT_FALSE(loaded.contains(6));
  const std::vector<Descriptor> query = random_descriptors(300, 55);
  const auto a = database.query(query), b = loaded.query(query);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].keyframe, b[i].keyframe);
    EXPECT_EQ(a[i].matched, b[i].matched);
  }
}

TEST(PlaceDatabase, TruncatedOrCorruptBytesAreRefusedWithAReason) {
  PlaceDatabase database;
  database.add(0, random_descriptors(200, 9));
  const std::vector<std::uint8_t> bytes = database.serialize();
  for (std::size_t size = 0; size < bytes.size(); size += 37) {
    const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size));
    EXPECT_THROW(PlaceDatabase::deserialize(cut), PlaceDatabaseError) << "cut at " << size;
  }
  std::vector<std::uint8_t> future = bytes;
  future[0] = 9;
  try {
    PlaceDatabase::deserialize(future);
    FAIL() << "a future version was accepted";
  } catch (const PlaceDatabaseError& e) {
    EXPECT_NE(std::string(e.what()).find("version 9"), std::string::npos) << e.what();
  }
  std::vector<std::uint8_t> huge = bytes;  // the keyframe count (after version, leaf size, distance)
  for (std::size_t i = 16; i < 24; ++i) huge[i] = 0xFF;
  EXPECT_THROW(PlaceDatabase::deserialize(huge), PlaceDatabaseError);
  std::vector<std::uint8_t> trailing = bytes;
  trailing.push_back(0);
  EXPECT_THROW(PlaceDatabase::deserialize(trailing), PlaceDatabaseError);
}

TEST(PlaceDatabase, BadOptionsAndDuplicateKeyframesAreRefused) {
  PlaceRecognitionOptions options;
  options.max_leaf_size = 1;
  EXPECT_THROW(PlaceDatabase{options}, std::invalid_argument);
  options = {};
  options.match_distance = 300;
  EXPECT_THROW(PlaceDatabase{options}, std::invalid_argument);
  PlaceDatabase database;
  database.add(4, random_descriptors(10, 1));
  EXPECT_THROW(database.add(4, random_descriptors(10, 2)), std::invalid_argument);
}

// Real images: the six Oxford sets (bark: zoom and rotation, bikes and trees: blur, leuven: light,
// ubc: JPEG, wall: viewpoint), 36 images in one database. Each of img1..img3 queried against the
// other 35 must score an image of its own set highest.
TEST(PlaceDatabase, OxfordImagesFindTheirOwnSetFirst) {
  const std::string why = test::image_loading_unavailable_reason();
  if (!why.empty()) GTEST_SKIP() << why;
  const char* sets[] = {"bark", "bikes", "leuven", "trees", "ubc", "wall"};
  for (const char* set : sets) {
    const std::string relative = std::string("oxford-affine/") + set + "/img1.png";
    if (test::data_file(relative).empty()) GTEST_SKIP() << test::skip_reason(relative);
  }
  std::unique_ptr<Backend> backend = BackendRegistry::instance().create("cpu", {});
  FrontendSettings settings;  // the frontend's defaults: 8 levels, 32-px cells
  std::map<std::pair<int, int>, std::unique_ptr<Frontend>> frontends;  // one per image size
  std::vector<std::vector<Descriptor>> images;
  PlaceDatabase database;
  for (int s = 0; s < 6; ++s) {
    for (int i = 1; i <= 6; ++i) {
      const Image image = test::load_gray(
          test::data_file(std::string("oxford-affine/") + sets[s] + "/img" + std::to_string(i) + ".png").string());
      auto& frontend = frontends[{image.width(), image.height()}];
      if (!frontend) frontend = std::make_unique<Frontend>(*backend, settings, image.width(), image.height());
      images.push_back(frontend->detect(image.view()).descriptors);
      database.add(static_cast<std::uint64_t>(6 * s + i - 1), images.back());
    }
  }
  for (int s = 0; s < 6; ++s) {
    for (int i = 1; i <= 3; ++i) {
      const auto id = static_cast<std::uint64_t>(6 * s + i - 1);
      const std::vector<std::uint64_t> exclude = {id};
      const std::vector<PlaceScore> scores = database.query(images[id], exclude);
      ASSERT_FALSE(scores.empty()) << sets[s] << " img" << i;
      int best_other = 0;  // the strongest image of another set, for the record
      for (const PlaceScore& score : scores) {
        if (score.keyframe / 6 != static_cast<std::uint64_t>(s)) {
          best_other = score.matched;
          break;
        }
      }
      std::printf("oxford %s img%d: %zu descriptors, best %d votes (image %llu), best other set %d\n", sets[s], i,
                  images[id].size(), scores.front().matched, static_cast<unsigned long long>(scores.front().keyframe),
                  best_other);
      EXPECT_EQ(scores.front().keyframe / 6, static_cast<std::uint64_t>(s))
          << sets[s] << " img" << i << " scored image " << scores.front().keyframe << " of set "
          << sets[scores.front().keyframe / 6] << " highest (" << scores.front().matched << " matches)";
    }
  }
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
