// Orientation (DESIGN.md §3.6) and ORB descriptor (§3.8) kernels of the cpu backend, against
// hand-built patterns and against straightforward re-implementations written here.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "porta/tables.hpp"
#include "support/test_images.hpp"
#include "unit/kernel_test_buffers.hpp"

namespace porta {
namespace {

using cpu::CpuBackend;

// ---- Helpers -------------------------------------------------------------------------------------

/// A pyramid whose levels are `levels` (sized as pyramid_level_sizes says), uploaded row by row.
struct DevicePyramid {
  PyramidLayout layout;
  std::unique_ptr<Buffer> buffer;
};

std::vector<std::pair<int, int>> level_sizes(int width, int height, int levels) {
  return pyramid_level_sizes(width, height, levels, 1.2);
}

DevicePyramid upload_pyramid(Backend& backend, const std::vector<Image>& levels) {
  DevicePyramid p;
  p.layout = PyramidLayout::make(
      level_sizes(levels[0].width(), levels[0].height(), static_cast<int>(levels.size())), 1);
  p.buffer = backend.allocate(static_cast<std::size_t>(p.layout.total_bytes));
  for (std::size_t n = 0; n < levels.size(); ++n) {
    const Plane& plane = p.layout.levels[n];
    EXPECT_EQ(levels[n].width(), plane.width) << "level " << n;
    EXPECT_EQ(levels[n].height(), plane.height) << "level " << n;
    for (int y = 0; y < plane.height; ++y)
      backend.upload(
          *p.buffer,
          static_cast<std::size_t>(plane.offset_bytes + static_cast<std::int64_t>(y) * plane.pitch),
          levels[n].row(y), static_cast<std::size_t>(plane.width));
  }
  return p;
}

/// A keypoint list with room for `capacity` records; the count sits at byte 8 of its buffer so
/// that count_offset_bytes is exercised.
struct DeviceKeypoints {
  std::unique_ptr<Buffer> items;
  std::unique_ptr<Buffer> count;
  DeviceList list;
};

DeviceKeypoints upload_keypoints(Backend& backend, const std::vector<Keypoint>& keypoints, int capacity = 0) {
  DeviceKeypoints k;
  const int n = static_cast<int>(keypoints.size());
  capacity = capacity > n ? capacity : n;
  k.items = backend.allocate(static_cast<std::size_t>(capacity) * sizeof(Keypoint));
  k.count = backend.allocate(16);
  if (n > 0) backend.upload(*k.items, 0, keypoints.data(), keypoints.size() * sizeof(Keypoint));
  const auto count = static_cast<std::uint32_t>(n);
  backend.upload(*k.count, 8, &count, sizeof(count));
  k.list = DeviceList{k.items.get(), k.count.get(), 8, capacity};
  return k;
}

template <typename T>
std::unique_ptr<Buffer> upload_vector(Backend& backend, const std::vector<T>& v) {
  auto b = backend.allocate(v.size() * sizeof(T));
  backend.upload(*b, 0, v.data(), v.size() * sizeof(T));
  return b;
}

/// Runs orient and returns the keypoints as written back.
std::vector<Keypoint> run_orient(CpuBackend& backend, const DevicePyramid& pyramid,
                                 const std::vector<Keypoint>& keypoints, int bins) {
  auto list = upload_keypoints(backend, keypoints);
  const auto boundaries = upload_vector(backend, build_orientation_boundaries(bins));
  backend.orient(*pyramid.buffer, pyramid.layout, list.list, build_orientation_umax(), *boundaries, bins);
  std::vector<Keypoint> out(keypoints.size());
  if (!out.empty()) backend.download(*list.items, 0, out.data(), out.size() * sizeof(Keypoint));
  return out;
}

std::vector<Descriptor> run_describe(CpuBackend& backend, const DevicePyramid& blurred,
                                     const std::vector<Keypoint>& keypoints, int bins) {
  auto list = upload_keypoints(backend, keypoints);
  const auto pattern = upload_vector(backend, build_orb_pattern_table(bins));
  auto descriptors = backend.allocate(keypoints.size() * sizeof(Descriptor));
  backend.orb_describe(*blurred.buffer, blurred.layout, list.list, *pattern, *descriptors);
  std::vector<Descriptor> out(keypoints.size());
  if (!out.empty()) backend.download(*descriptors, 0, out.data(), out.size() * sizeof(Descriptor));
  return out;
}

using test::keypoint_at;

/// An image whose pixel (x, y) is `value(x, y)`.
template <typename F>
Image image_of(int width, int height, F value) {
  Image img(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) img.at(x, y) = static_cast<std::uint8_t>(value(x, y));
  return img;
}

/// Keypoints on a grid of the given step, at least 19 px from the border of a level.
std::vector<Keypoint> grid_keypoints(int width, int height, int level, int step) {
  std::vector<Keypoint> k;
  for (int y = 19; y + 19 < height; y += step)
    for (int x = 19; x + 19 < width; x += step) k.push_back(keypoint_at(x, y, level));
  return k;
}

// ---- Orientation ---------------------------------------------------------------------------------

constexpr int kSize = 48;
constexpr int kCentre = 24;

int orient_one(const Image& image, int bins) {
  CpuBackend backend(2);
  const auto pyramid = upload_pyramid(backend, {image});
  return run_orient(backend, pyramid, {keypoint_at(kCentre, kCentre)}, bins)[0].angle_bin;
}

// A half-plane through the keypoint's column or row makes one moment 0 by the disc's mirror
// symmetry and the other one positive or negative, so the centroid points exactly along an axis:
// right = angle 0, bottom (y grows downward) = pi/2, left = pi, top = 3pi/2. Each axis is a bin
// centre when bins % 4 == 0.
TEST(Orientation, HalfPlanesGiveTheFourAxisBins) {
  const Image right = image_of(kSize, kSize, [](int x, int) { return x > kCentre ? 200 : 10; });
  const Image bottom = image_of(kSize, kSize, [](int, int y) { return y > kCentre ? 200 : 10; });
  const Image left = image_of(kSize, kSize, [](int x, int) { return x < kCentre ? 200 : 10; });
  const Image top = image_of(kSize, kSize, [](int, int y) { return y < kCentre ? 200 : 10; });
  for (int bins : {4, 8, 12, 32, 64}) {
    SCOPED_TRACE(bins);
    EXPECT_EQ(orient_one(right, bins), 0);
    EXPECT_EQ(orient_one(bottom, bins), bins / 4);
    EXPECT_EQ(orient_one(left, bins), bins / 2);
    EXPECT_EQ(orient_one(top, bins), 3 * bins / 4);
  }
}

// A centroid exactly along boundary u_k has cross(u_k, m) = 0 >= 0 and cross(u_{k+1}, m) < 0, so it
// belongs to bin k (the bin that starts there), never to bin k-1, whose test needs cross(u_k, m) < 0.
// With 6 bins the boundaries lie at 30 + 60k degrees: bottom (90) is boundary 2, top (270)
// boundary 5. With 4 bins they lie at 45 + 90(k-1) degrees: a half-plane cut along the
// anti-diagonal gives m10 = m01 by its mirror symmetry, on boundary 1 (45) or boundary 3 (225).
TEST(Orientation, CentroidOnABoundaryGoesToTheBinStartingThere) {
  const auto six = build_orientation_boundaries(6);
  ASSERT_EQ(six[2 * 2], 0);  // u_2 = (0, 1024) exactly
  ASSERT_EQ(six[2 * 5], 0);  // u_5 = (0, -1024) exactly
  const auto four = build_orientation_boundaries(4);
  ASSERT_EQ(four[2 * 1], four[2 * 1 + 1]);  // u_1 along the diagonal exactly
  ASSERT_EQ(four[2 * 3], four[2 * 3 + 1]);
  const Image bottom = image_of(kSize, kSize, [](int, int y) { return y > kCentre ? 200 : 10; });
  const Image top = image_of(kSize, kSize, [](int, int y) { return y < kCentre ? 200 : 10; });
  const Image bottom_right =
      image_of(kSize, kSize, [](int x, int y) { return x + y > 2 * kCentre ? 200 : 10; });
  const Image top_left = image_of(kSize, kSize, [](int x, int y) { return x + y < 2 * kCentre ? 200 : 10; });
  EXPECT_EQ(orient_one(bottom, 6), 2);
  EXPECT_EQ(orient_one(top, 6), 5);
  EXPECT_EQ(orient_one(bottom_right, 4), 1);
  EXPECT_EQ(orient_one(top_left, 4), 3);
}

// m = (0, 0) meets no bin's condition; the contract sends it to bin 0.
TEST(Orientation, FlatPatchGivesBin0) {
  for (int value : {0, 77, 255})
    EXPECT_EQ(orient_one(test::flat_image(kSize, kSize, static_cast<std::uint8_t>(value)), 32), 0);
}

// A patch symmetric under a half turn about the keypoint (an X of two bright diagonals through
// it) has I(-d) = I(d), so both moments cancel and m = 0 too.
TEST(Orientation, CentrallySymmetricPatchGivesBin0) {
  const Image cross_lines = image_of(kSize, kSize, [](int x, int y) {
    return (x - kCentre == y - kCentre || x - kCentre == kCentre - y) ? 250 : 30;
  });
  EXPECT_EQ(orient_one(cross_lines, 32), 0);
}

/// A bright wedge of half-angle `half_width` around direction `theta` from the patch centre on a
/// dark background, drawn analytically: each pixel's brightness is its covered fraction, from
/// 8 x 8 sub-samples. Its intensity centroid points along theta up to sampling error.
Image wedge_image(double theta, double half_width) {
  Image img = test::flat_image(kSize, kSize, 20);
  constexpr int kSub = 8;
  for (int y = kCentre - 16; y <= kCentre + 16; ++y)
    for (int x = kCentre - 16; x <= kCentre + 16; ++x) {
      int covered = 0;
      for (int sy = 0; sy < kSub; ++sy)
        for (int sx = 0; sx < kSub; ++sx) {
          const double px = x - kCentre + (sx + 0.5) / kSub - 0.5;
          const double py = y - kCentre + (sy + 0.5) / kSub - 0.5;
          if (std::abs(std::remainder(std::atan2(py, px) - theta, 2 * std::numbers::pi)) <= half_width)
            ++covered;
        }
      img.at(x, y) = static_cast<std::uint8_t>(20 + std::lround(220.0 * covered / (kSub * kSub)));
    }
  return img;
}

// theta = k * 2pi/32 is the centre of bin k, 5.6 degrees from either boundary, far more than the
// wedge's sampling error: every k must come back exactly.
TEST(Orientation, WedgeAtEachBinCentreGivesThatBin) {
  constexpr int kBins = 32;
  for (int k = 0; k < kBins; ++k) {
    const double theta = 2 * std::numbers::pi * k / kBins;
    EXPECT_EQ(orient_one(wedge_image(theta, std::numbers::pi / 6), kBins), k) << "theta = " << theta;
    EXPECT_EQ(orient_one(wedge_image(theta, std::numbers::pi / 2.5), kBins), k)
        << "wide wedge, theta = " << theta;
  }
}

/// The contract's bin written independently: moments over the whole square with the disc test
/// dx^2 + dy^2 <= 240, then atan2 in double. Returns -1 when the angle is within 0.5 degrees of a
/// bin boundary (where rounding the boundary vectors to 1/1024 may decide) or m = 0.
int bin_by_atan2(const Image& level, int cx, int cy, int bins) {
  long m10 = 0, m01 = 0;
  for (int dy = -15; dy <= 15; ++dy)
    for (int dx = -15; dx <= 15; ++dx)
      if (dx * dx + dy * dy <= 240) {
        m10 += dx * level.at(cx + dx, cy + dy);
        m01 += dy * level.at(cx + dx, cy + dy);
      }
  if (m10 == 0 && m01 == 0) return -1;
  const double in_bins =
      std::atan2(static_cast<double>(m01), static_cast<double>(m10)) / (2 * std::numbers::pi) * bins;
  const double shifted = in_bins + 0.5;  // boundaries sit at integers of `shifted`
  const double to_boundary_deg = std::abs(shifted - std::round(shifted)) * 360.0 / bins;
  if (to_boundary_deg < 0.5) return -1;
  const int bin = static_cast<int>(std::floor(shifted));
  return ((bin % bins) + bins) % bins;
}

TEST(Orientation, MatchesAtan2OfTheCentroidOnTexturedAndRandomLevels) {
  const auto sizes = level_sizes(150, 110, 2);
  for (int image_kind = 0; image_kind < 2; ++image_kind) {
    std::vector<Image> levels;
    for (std::size_t n = 0; n < sizes.size(); ++n) {
      const auto seed = 11 + n;
      levels.push_back(image_kind == 0 ? test::textured_image(sizes[n].first, sizes[n].second, seed)
                                       : test::random_image(sizes[n].first, sizes[n].second, seed));
    }
    CpuBackend backend(2);
    const auto pyramid = upload_pyramid(backend, levels);
    std::vector<Keypoint> keypoints;
    for (int n = 0; n < 2; ++n) {
      const auto k = grid_keypoints(sizes[n].first, sizes[n].second, n, 2);
      keypoints.insert(keypoints.end(), k.begin(), k.end());
    }
    for (int bins : {8, 32, 64}) {
      const auto oriented = run_orient(backend, pyramid, keypoints, bins);
      int compared = 0;
      for (std::size_t i = 0; i < keypoints.size(); ++i) {
        const Keypoint& k = keypoints[i];
        const int expected = bin_by_atan2(levels[k.level], k.x, k.y, bins);
        if (expected < 0) continue;
        ++compared;
        ASSERT_EQ(oriented[i].angle_bin, expected)
            << "kind " << image_kind << ", bins " << bins << ", keypoint (" << k.x << ", " << k.y
            << ") level " << int{k.level};
      }
      // Near-boundary skips must stay rare, or the comparison would prove little.
      EXPECT_GT(compared, static_cast<int>(keypoints.size()) * 8 / 10) << "bins " << bins;
    }
  }
}

// The keypoint's level picks the image: level 0 is bright on the right, level 1 on the left.
// Only angle_bin changes; records past the list's count are not touched.
TEST(Orientation, ReadsTheKeypointsLevelAndWritesOnlyAngleBinOfListedRecords) {
  const auto sizes = level_sizes(64, 64, 2);
  const Image level0 = image_of(sizes[0].first, sizes[0].second, [](int x, int) { return x > 30 ? 220 : 5; });
  const Image level1 = image_of(sizes[1].first, sizes[1].second, [](int x, int) { return x < 26 ? 220 : 5; });
  CpuBackend backend(2);
  const auto pyramid = upload_pyramid(backend, {level0, level1});
  Keypoint on0 = keypoint_at(30, 30, 0, 77), on1 = keypoint_at(26, 26, 1, 77),
           beyond = keypoint_at(30, 30, 0, 99);
  on0.response = 1234;
  on1.response = 4321;
  auto list = upload_keypoints(backend, {on0, on1, beyond});
  const std::uint32_t two = 2;  // the third record lies past the count
  backend.upload(*list.count, 8, &two, sizeof(two));
  const auto boundaries = upload_vector(backend, build_orientation_boundaries(32));
  backend.orient(*pyramid.buffer, pyramid.layout, list.list, build_orientation_umax(), *boundaries, 32);
  Keypoint out[3];
  backend.download(*list.items, 0, out, sizeof(out));
  EXPECT_EQ(out[0].angle_bin, 0);
  EXPECT_EQ(out[1].angle_bin, 16);
  EXPECT_EQ(out[2].angle_bin, 99);
  on0.angle_bin = 0;
  on1.angle_bin = 16;
  EXPECT_EQ(std::memcmp(&out[0], &on0, sizeof(Keypoint)), 0);
  EXPECT_EQ(std::memcmp(&out[1], &on1, sizeof(Keypoint)), 0);
}

TEST(Orientation, EmptyListIsANoOp) {
  CpuBackend backend(2);
  const auto pyramid = upload_pyramid(backend, {test::random_image(64, 64, 3)});
  EXPECT_TRUE(run_orient(backend, pyramid, {}, 32).empty());
}

TEST(Orientation, KeypointWhosePatchLeavesTheLevelIsAnError) {
  CpuBackend backend(2);
  const auto pyramid = upload_pyramid(backend, {test::random_image(64, 64, 3)});
  EXPECT_THROW(run_orient(backend, pyramid, {keypoint_at(14, 30)}, 32), BackendError);
  EXPECT_THROW(run_orient(backend, pyramid, {keypoint_at(30, 49)}, 32), BackendError);
  EXPECT_THROW(run_orient(backend, pyramid, {keypoint_at(30, 30, 1)}, 32), BackendError);  // no level 1
  EXPECT_NO_THROW(run_orient(backend, pyramid, {keypoint_at(15, 48)}, 32));
}

// ---- ORB descriptor ------------------------------------------------------------------------------

using Point = std::pair<int, int>;
Point point_a(const std::array<std::int8_t, 4>& pair) { return {pair[0], pair[1]}; }
Point point_b(const std::array<std::int8_t, 4>& pair) { return {pair[2], pair[3]}; }

bool bit_of(const Descriptor& d, int j) { return ((d.bytes[j / 8] >> (j % 8)) & 1) != 0; }

// Bin 0's table is the unrotated base pattern (cos 0 = 1, sin 0 = 0). On a flat image, make
// pair 0's first point darker than its second and pair 1's first point brighter than its second:
// bit 0 = (40 < 200) = 1 and bit 1 = (200 < 40) = 0, i.e. byte 0 ends in binary 01; swapping the
// values gives 10.
TEST(OrbDescriptor, Pair0AndPair1FillBits0And1OfByte0) {
  const auto& base = orb_base_pattern();
  const Point a0 = point_a(base[0]), b0 = point_b(base[0]), a1 = point_a(base[1]), b1 = point_b(base[1]);
  ASSERT_TRUE(a0 != b0 && a0 != a1 && a0 != b1 && b0 != a1 && b0 != b1 && a1 != b1)
      << "pairs 0 and 1 share a point: this test needs four distinct points";
  const auto describe = [&](int dark_first, int bright_first) {
    Image img = test::flat_image(kSize, kSize, 100);
    img.at(kCentre + a0.first, kCentre + a0.second) = static_cast<std::uint8_t>(dark_first);
    img.at(kCentre + b0.first, kCentre + b0.second) = static_cast<std::uint8_t>(bright_first);
    img.at(kCentre + a1.first, kCentre + a1.second) = static_cast<std::uint8_t>(bright_first);
    img.at(kCentre + b1.first, kCentre + b1.second) = static_cast<std::uint8_t>(dark_first);
    CpuBackend backend(2);
    return run_describe(backend, upload_pyramid(backend, {img}), {keypoint_at(kCentre, kCentre)}, 32)[0];
  };
  EXPECT_EQ(describe(40, 200).bytes[0] & 0x3, 0x1);
  EXPECT_EQ(describe(200, 40).bytes[0] & 0x3, 0x2);
}

// One pixel darker than a flat background sets exactly the bits of the pairs whose first point
// it is (I(a) = 40 < 100 = I(b)); pairs with it as second point read 100 < 40 = 0. Checked for
// pairs spread over all bytes and bit positions, and for several bins, whose tables start at
// bin * 256 * 4.
TEST(OrbDescriptor, OneDarkPixelSetsTheBitsOfThePairsStartingThere) {
  const auto table = build_orb_pattern_table(32);
  for (int bin : {0, 5, 31}) {
    for (int j : {0, 1, 7, 8, 100, 255}) {
      SCOPED_TRACE(testing::Message() << "bin " << bin << ", pair " << j);
      const std::int8_t* pairs = table.data() + static_cast<std::size_t>(bin) * kOrbPairs * 4;
      const Point dark{pairs[j * 4], pairs[j * 4 + 1]};
      Image img = test::flat_image(kSize, kSize, 100);
      img.at(kCentre + dark.first, kCentre + dark.second) = 40;
      CpuBackend backend(2);
      const Descriptor d = run_describe(backend, upload_pyramid(backend, {img}),
                                        {keypoint_at(kCentre, kCentre, 0, bin)}, 32)[0];
      Descriptor expected;
      for (int k = 0; k < kOrbPairs; ++k)
        if (Point{pairs[k * 4], pairs[k * 4 + 1]} == dark)
          expected.bytes[k / 8] |= static_cast<std::uint8_t>(1u << (k % 8));
      EXPECT_TRUE(bit_of(d, j));
      EXPECT_EQ(d.bytes, expected.bytes);
    }
  }
  // Pair 255 is the most significant bit of the last byte.
  Image img = test::flat_image(kSize, kSize, 100);
  img.at(kCentre + orb_base_pattern()[255][0], kCentre + orb_base_pattern()[255][1]) = 40;
  CpuBackend backend(2);
  EXPECT_EQ(run_describe(backend, upload_pyramid(backend, {img}), {keypoint_at(kCentre, kCentre)}, 32)[0]
                    .bytes[31] &
                0x80,
            0x80);
}

// Equal intensities never set a bit: the test is strictly less-than.
TEST(OrbDescriptor, FlatImageGivesAllZeroDescriptors) {
  CpuBackend backend(2);
  const auto pyramid = upload_pyramid(backend, {test::flat_image(80, 64, 128)});
  std::vector<Keypoint> keypoints = grid_keypoints(80, 64, 0, 5);
  for (std::size_t i = 0; i < keypoints.size(); ++i)
    keypoints[i].angle_bin = static_cast<std::uint8_t>(i % 32);
  for (const Descriptor& d : run_describe(backend, pyramid, keypoints, 32))
    EXPECT_EQ(d.bytes, Descriptor{}.bytes);
}

/// The descriptor written independently: the 256 tests go into four 64-bit words, which are then
/// cut into bytes least significant first.
Descriptor naive_descriptor(const Image& level, const Keypoint& k, const std::vector<std::int8_t>& table) {
  std::uint64_t words[4] = {0, 0, 0, 0};
  for (int j = 0; j < kOrbPairs; ++j) {
    const auto* p = &table[(static_cast<std::size_t>(k.angle_bin) * kOrbPairs + j) * 4];
    if (level.at(k.x + p[0], k.y + p[1]) < level.at(k.x + p[2], k.y + p[3]))
      words[j / 64] |= std::uint64_t{1} << (j % 64);
  }
  Descriptor d;
  for (int i = 0; i < 32; ++i) d.bytes[i] = static_cast<std::uint8_t>(words[i / 8] >> (8 * (i % 8)));
  return d;
}

TEST(OrbDescriptor, MatchesANaiveImplementationOnRandomImages) {
  const auto sizes = level_sizes(130, 90, 3);
  std::vector<Image> levels;
  for (std::size_t n = 0; n < sizes.size(); ++n)
    levels.push_back(test::random_image(sizes[n].first, sizes[n].second, 40 + n));
  CpuBackend backend(2);
  const auto pyramid = upload_pyramid(backend, levels);
  std::mt19937 rng(7);
  for (int bins : {8, 32, 64}) {
    std::vector<Keypoint> keypoints;
    for (int n = 0; n < 3; ++n)
      for (const Keypoint& k : grid_keypoints(sizes[n].first, sizes[n].second, n, 3)) {
        Keypoint with_bin = k;
        with_bin.angle_bin = static_cast<std::uint8_t>(rng() % static_cast<unsigned>(bins));
        keypoints.push_back(with_bin);
      }
    const auto table = build_orb_pattern_table(bins);
    const auto descriptors = run_describe(backend, pyramid, keypoints, bins);
    for (std::size_t i = 0; i < keypoints.size(); ++i)
      ASSERT_EQ(descriptors[i].bytes, naive_descriptor(levels[keypoints[i].level], keypoints[i], table).bytes)
          << "bins " << bins << ", keypoint " << i;
  }
}

TEST(OrbDescriptor, KeypointWhosePatternLeavesTheLevelIsAnError) {
  CpuBackend backend(2);
  const auto pyramid = upload_pyramid(backend, {test::random_image(64, 64, 3)});
  EXPECT_THROW(run_describe(backend, pyramid, {keypoint_at(17, 30)}, 32), BackendError);
  EXPECT_THROW(run_describe(backend, pyramid, {keypoint_at(30, 46)}, 32), BackendError);
  EXPECT_THROW(run_describe(backend, pyramid, {keypoint_at(30, 30, 0, 32)}, 32),
               BackendError);  // bin 32 of 32
  EXPECT_NO_THROW(run_describe(backend, pyramid, {keypoint_at(18, 45)}, 32));
}

// ---- Rotation end to end -------------------------------------------------------------------------

// Turning an N x N image by 90 degrees (x' = N-1-y, y' = x) turns every offset d around a keypoint
// into R(d) = (-d.y, d.x): the keypoint (x, y) moves to (N-1-y, x), its centroid turns by a quarter
// (the disc is symmetric under R), so its bin moves by bins/4, and the pattern of that bin is R of
// the old one, so every pair samples the same two pixels: the descriptor must not change.
TEST(Rotation, QuarterTurnShiftsTheBinByAQuarterAndKeepsTheDescriptor) {
  for (int bins : {4, 8, 16, 32, 64}) {
    SCOPED_TRACE(bins);
    // Preconditions on the shared tables: both are exactly quarter-turn symmetric.
    const auto table = build_orb_pattern_table(bins);
    const auto boundaries = build_orientation_boundaries(bins);
    for (int b = 0; b < bins; ++b) {
      const int turned = (b + bins / 4) % bins;
      ASSERT_EQ(boundaries[2 * turned], -boundaries[2 * b + 1]) << "boundary " << b;
      ASSERT_EQ(boundaries[2 * turned + 1], boundaries[2 * b]) << "boundary " << b;
      for (int j = 0; j < kOrbPairs; ++j)
        for (int pt = 0; pt < 2; ++pt) {
          const auto at = [&](int bin, int c) {
            return table[(static_cast<std::size_t>(bin) * kOrbPairs + j) * 4 + 2 * pt + c];
          };
          ASSERT_EQ(at(turned, 0), -at(b, 1)) << "bin " << b << ", pair " << j;
          ASSERT_EQ(at(turned, 1), at(b, 0)) << "bin " << b << ", pair " << j;
        }
    }

    constexpr int kN = 101;
    const Image image = test::random_image(kN, kN, 5);
    const Image turned = image_of(kN, kN, [&](int x, int y) { return image.at(y, kN - 1 - x); });
    CpuBackend backend(2);
    const auto pyramid = upload_pyramid(backend, {image});
    const auto turned_pyramid = upload_pyramid(backend, {turned});
    const auto keypoints = grid_keypoints(kN, kN, 0, 2);
    std::vector<Keypoint> turned_keypoints;
    for (const Keypoint& k : keypoints) turned_keypoints.push_back(keypoint_at(kN - 1 - k.y, k.x));

    const auto oriented = run_orient(backend, pyramid, keypoints, bins);
    const auto turned_oriented = run_orient(backend, turned_pyramid, turned_keypoints, bins);
    const auto descriptors = run_describe(backend, pyramid, oriented, bins);
    const auto turned_descriptors = run_describe(backend, turned_pyramid, turned_oriented, bins);
    int distinct_bins = 0;
    std::vector<bool> seen(static_cast<std::size_t>(bins), false);
    for (std::size_t i = 0; i < keypoints.size(); ++i) {
      ASSERT_EQ(turned_oriented[i].angle_bin, (oriented[i].angle_bin + bins / 4) % bins) << "keypoint " << i;
      ASSERT_EQ(turned_descriptors[i].bytes, descriptors[i].bytes) << "keypoint " << i;
      if (!seen[oriented[i].angle_bin]) ++distinct_bins;
      seen[oriented[i].angle_bin] = true;
    }
    EXPECT_EQ(distinct_bins, bins) << "the keypoints should cover every bin";
  }
}

// ---- Threads -------------------------------------------------------------------------------------

TEST(DescribeKernels, ResultsDoNotDependOnTheThreadCount) {
  const auto sizes = level_sizes(200, 150, 2);
  std::vector<Image> levels;
  for (std::size_t n = 0; n < sizes.size(); ++n)
    levels.push_back(test::textured_image(sizes[n].first, sizes[n].second, 90 + n));
  std::vector<Keypoint> keypoints;
  for (int n = 0; n < 2; ++n) {
    const auto k = grid_keypoints(sizes[n].first, sizes[n].second, n, 2);
    keypoints.insert(keypoints.end(), k.begin(), k.end());
  }
  std::vector<Keypoint> oriented[2];
  std::vector<Descriptor> descriptors[2];
  const int threads[2] = {1, 5};
  for (int t = 0; t < 2; ++t) {
    CpuBackend backend(threads[t]);
    const auto pyramid = upload_pyramid(backend, levels);
    oriented[t] = run_orient(backend, pyramid, keypoints, 32);
    descriptors[t] = run_describe(backend, pyramid, oriented[t], 32);
  }
  ASSERT_EQ(oriented[0].size(), keypoints.size());
  EXPECT_EQ(std::memcmp(oriented[0].data(), oriented[1].data(), keypoints.size() * sizeof(Keypoint)), 0);
  EXPECT_EQ(std::memcmp(descriptors[0].data(), descriptors[1].data(), keypoints.size() * sizeof(Descriptor)),
            0);
}

}  // namespace
}  // namespace porta
