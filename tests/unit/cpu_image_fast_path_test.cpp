// The cpu backend's vectorised kernels (pyramid §3.2, blur §3.7, orientation §3.6, ORB descriptor
// §3.8) against plain scalar loops written here from the contracts, on sizes chosen to hit every
// vector tail and border case: widths that are not multiples of 8, 16 or 32, levels of a few
// pixels where the blur's reflect-101 borders overlap, keypoints as close to the border as allowed.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "porta/tables.hpp"
#include "support/test_images.hpp"
#include "unit/contract_pyramid.hpp"
#include "unit/kernel_test_buffers.hpp"

namespace porta {
namespace {

using Sizes = std::vector<std::pair<int, int>>;
using Taps = std::array<std::int32_t, 7>;

std::string size_name(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// ---- Pyramid (§3.2) ------------------------------------------------------------------------------

TEST(CpuFastPath, PyramidMatchesTheScalarContractOnOddSizesAndAllLevelCounts) {
  cpu::CpuBackend backend(2);
  const Sizes bases = {{7, 5}, {8, 8}, {37, 29}, {65, 33}, {1, 9}, {33, 1}, {1242, 375}};
  for (const auto& [width, height] : bases)
    for (const double scale : {1.2, 2.0})
      for (int levels = 1; levels <= 12; ++levels) {
        if (width * height > 10000 && levels % 4 != 0 && levels != 1) continue;  // keep it quick
        const Sizes sizes = pyramid_level_sizes(width, height, levels, scale);
        const Image image = test::random_image(width, height, 7u * width + height);
        // An odd level-0 pitch moves every row of level 0 off any alignment.
        const PyramidLayout layout = PyramidLayout::make(sizes, 1, width + 3);
        const ResizeTables tables = build_resize_tables(sizes);
        auto pyramid = test::upload_levels(backend, layout, {image});
        const auto table = test::upload_vector(backend, tables.packed);
        backend.build_pyramid(*pyramid, layout, *table, tables.level_offset);
        const auto actual = test::download_levels(backend, *pyramid, layout);
        const auto expected = test::contract_pyramid(image, sizes);
        for (std::size_t n = 0; n < sizes.size(); ++n)
          test::expect_same_image(actual[n], expected[n],
                                  size_name(width, height) + " scale " + std::to_string(scale) + ", " +
                                      std::to_string(levels) + " levels, level " + std::to_string(n));
      }
}

// The blend bound of the comment in image_kernels.cpp: all 255 gives the largest sums.
TEST(CpuFastPath, PyramidOfAWhiteImageStaysWhite) {
  cpu::CpuBackend backend(2);
  const Sizes sizes = pyramid_level_sizes(1242, 375, 8, 1.2);
  const PyramidLayout layout = PyramidLayout::make(sizes, 1);
  const ResizeTables tables = build_resize_tables(sizes);
  auto pyramid = test::upload_levels(backend, layout, {test::flat_image(1242, 375, 255)});
  const auto table = test::upload_vector(backend, tables.packed);
  backend.build_pyramid(*pyramid, layout, *table, tables.level_offset);
  const auto levels = test::download_levels(backend, *pyramid, layout);
  for (std::size_t n = 0; n < sizes.size(); ++n)
    test::expect_same_image(levels[n], test::flat_image(sizes[n].first, sizes[n].second, 255),
                            "level " + std::to_string(n));
}

// ---- Blur (§3.7) ---------------------------------------------------------------------------------

/// Reflect-101 by stepping (-1 -> 1, n -> n - 2, repeated), written apart from reflect101().
int mirror(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * (n - 1) - i;
  return i;
}

/// The contract's double sum, (sum_ky t_ky * sum_kx t_kx * p + 2^15) >> 16, pixel by pixel.
Image scalar_blur(const Image& src, const Taps& taps) {
  Image out(src.width(), src.height());
  for (int y = 0; y < src.height(); ++y)
    for (int x = 0; x < src.width(); ++x) {
      std::int64_t sum = 0;
      for (int ky = -3; ky <= 3; ++ky)
        for (int kx = -3; kx <= 3; ++kx)
          sum += std::int64_t{taps[ky + 3]} * taps[kx + 3] *
                 src.at(mirror(x + kx, src.width()), mirror(y + ky, src.height()));
      out.at(x, y) = static_cast<std::uint8_t>((sum + (1 << 15)) >> 16);
    }
  return out;
}

/// Blurs `images` as the levels of one pyramid (level 0 with an odd pitch) and checks each.
void expect_blur_matches_scalar(cpu::CpuBackend& backend, const std::vector<Image>& images, const Taps& taps,
                                const std::string& what) {
  Sizes sizes;
  for (const Image& img : images) sizes.emplace_back(img.width(), img.height());
  const PyramidLayout layout = PyramidLayout::make(sizes, 1, images[0].width() + 5);
  const auto pyramid = test::upload_levels(backend, layout, images);
  auto blurred = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  backend.blur(*pyramid, layout, *blurred, taps);
  const auto out = test::download_levels(backend, *blurred, layout);
  for (std::size_t n = 0; n < images.size(); ++n)
    test::expect_same_image(
        out[n], scalar_blur(images[n], taps),
        what + ", level " + std::to_string(n) + " " + size_name(sizes[n].first, sizes[n].second));
}

/// Tap sets that sum to 256: the real one, one-hot at each end and in the middle (the vertical
/// and horizontal passes must not be swapped or shifted), asymmetric ones and random ones.
std::vector<Taps> tap_sets() {
  std::vector<Taps> sets = {build_blur_taps(),           {256, 0, 0, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0, 256},
                            {0, 0, 0, 256, 0, 0, 0},     {1, 2, 3, 4, 5, 6, 235}, {100, 0, 50, 0, 6, 0, 100},
                            {37, 37, 37, 37, 37, 37, 34},
                            // Symmetric (the mirrored-pairs path), with the extreme outer taps.
                            {128, 0, 0, 0, 0, 0, 128},   {60, 20, 10, 76, 10, 20, 60}};
  std::mt19937 rng(42);
  for (int s = 0; s < 4; ++s) {
    Taps t{};
    int left = 256;
    for (int k = 0; k < 6; ++k) {
      t[k] = static_cast<std::int32_t>(rng() % static_cast<unsigned>(left + 1) / 2);
      left -= t[k];
    }
    t[6] = left;
    sets.push_back(t);
  }
  return sets;
}

TEST(CpuFastPath, BlurMatchesTheScalarContractOnEveryWidthUpTo40) {
  cpu::CpuBackend backend(2);
  // Widths 1..40 cover the 16-column vertical and 8-column horizontal steps with every tail
  // length, and widths < 7 where the reflected borders overlap; heights 1..7 likewise.
  std::vector<Image> images;
  for (int width = 1; width <= 40; ++width)
    images.push_back(test::random_image(width, 1 + width % 7, 100u + static_cast<unsigned>(width)));
  for (const Taps& taps : tap_sets()) expect_blur_matches_scalar(backend, images, taps, "widths 1..40");
}

TEST(CpuFastPath, BlurMatchesTheScalarContractOnLargerOddLevels) {
  cpu::CpuBackend backend(2);
  const Sizes sizes = {{1242, 375}, {65, 33}, {37, 29}, {7, 64}, {8, 8}, {3, 3}, {1, 1}, {2, 2}};
  std::vector<Image> images;
  for (std::size_t n = 0; n < sizes.size(); ++n)
    images.push_back(test::random_image(sizes[n].first, sizes[n].second, 900u + n));
  for (const Taps& taps : {tap_sets()[0], tap_sets()[4], tap_sets()[8]})
    expect_blur_matches_scalar(backend, images, taps, "odd levels");
  // All 255: the largest intermediate sums (256 * 255 per pass).
  expect_blur_matches_scalar(backend, {test::flat_image(77, 9, 255), test::flat_image(5, 4, 255)},
                             tap_sets()[0], "white");
}

// ---- Orientation (§3.6) --------------------------------------------------------------------------

/// The contract: m10 = sum dx * I, m01 = sum dy * I over |dy| <= 15, |dx| <= umax[|dy|]; the first
/// bin b with cross(u_b, m) >= 0 > cross(u_{b+1 mod B}, m), else 0.
int scalar_orientation_bin(const Image& level, int cx, int cy, int bins) {
  const auto umax = build_orientation_umax();
  const auto u = build_orientation_boundaries(bins);
  std::int64_t m10 = 0, m01 = 0;
  for (int dy = -15; dy <= 15; ++dy)
    for (int dx = -umax[std::abs(dy)]; dx <= umax[std::abs(dy)]; ++dx) {
      m10 += dx * level.at(cx + dx, cy + dy);
      m01 += dy * level.at(cx + dx, cy + dy);
    }
  const auto cross = [&](int b) { return u[2 * b] * m01 - u[2 * b + 1] * m10; };
  for (int b = 0; b < bins; ++b)
    if (cross(b) >= 0 && cross((b + 1) % bins) < 0) return b;
  return 0;
}

using test::keypoint_at;

/// Every keypoint position at least `reach` px from the border of each level.
std::vector<Keypoint> all_keypoints(const std::vector<Image>& levels, int reach) {
  std::vector<Keypoint> k;
  for (std::size_t n = 0; n < levels.size(); ++n)
    for (int y = reach; y + reach < levels[n].height(); ++y)
      for (int x = reach; x + reach < levels[n].width(); ++x)
        k.push_back(keypoint_at(x, y, static_cast<int>(n)));
  return k;
}

TEST(CpuFastPath, OrientationMatchesTheScalarContractAtEveryPositionAndBin) {
  cpu::CpuBackend backend(2);
  // Level 0 31 px wide: one keypoint per row, its disc touching both sides; white pins the
  // largest moments; the others random and textured.
  const std::vector<Image> levels = {test::random_image(31, 40, 5), test::flat_image(33, 31, 255),
                                     test::random_image(70, 45, 6), test::textured_image(77, 61, 7)};
  const Sizes sizes = {{31, 40}, {33, 31}, {70, 45}, {77, 61}};
  const PyramidLayout layout = PyramidLayout::make(sizes, 1, 31 + 7);
  const auto pyramid = test::upload_levels(backend, layout, levels);
  const std::vector<Keypoint> keypoints = all_keypoints(levels, kOrientationRadius);
  for (const int bins : {1, 7, 32, 64}) {
    auto list = test::upload_keypoint_list(backend, keypoints);
    const auto boundaries = test::upload_vector(backend, build_orientation_boundaries(bins));
    backend.orient(*pyramid, layout, list.list, build_orientation_umax(), *boundaries, bins);
    std::vector<Keypoint> out(keypoints.size());
    backend.download(*list.items, 0, out.data(), out.size() * sizeof(Keypoint));
    std::set<int> seen;
    for (std::size_t i = 0; i < keypoints.size(); ++i) {
      const Keypoint& k = keypoints[i];
      const int expected = scalar_orientation_bin(levels[k.level], k.x, k.y, bins);
      seen.insert(expected);
      ASSERT_EQ(out[i].angle_bin, expected)
          << bins << " bins, keypoint (" << k.x << ", " << k.y << ") level " << int{k.level};
    }
    EXPECT_EQ(static_cast<int>(seen.size()), bins) << "the inputs should reach every bin";
  }
}

// ---- ORB descriptor (§3.8) -----------------------------------------------------------------------

TEST(CpuFastPath, DescriptorsMatchTheScalarContractAtEveryPositionAndBin) {
  cpu::CpuBackend backend(2);
  constexpr int kReach = 18;  // the rotated pattern lies within [-18, 18]
  const std::vector<Image> levels = {test::random_image(37, 40, 8), test::random_image(53, 39, 9),
                                     test::textured_image(90, 41, 10)};
  const Sizes sizes = {{37, 40}, {53, 39}, {90, 41}};
  const PyramidLayout layout = PyramidLayout::make(sizes, 1, 37 + 3);
  const auto pyramid = test::upload_levels(backend, layout, levels);
  for (const int bins : {1, 32, 64}) {
    std::vector<Keypoint> keypoints = all_keypoints(levels, kReach);
    for (std::size_t i = 0; i < keypoints.size(); ++i)
      keypoints[i].angle_bin = static_cast<std::uint8_t>((i * 7) % static_cast<std::size_t>(bins));
    const std::vector<std::int8_t> pattern = build_orb_pattern_table(bins);
    auto list = test::upload_keypoint_list(backend, keypoints);
    const auto pattern_buffer = test::upload_vector(backend, pattern);
    auto descriptors = backend.allocate(keypoints.size() * sizeof(Descriptor));
    backend.orb_describe(*pyramid, layout, list.list, *pattern_buffer, *descriptors);
    std::vector<Descriptor> out(keypoints.size());
    backend.download(*descriptors, 0, out.data(), out.size() * sizeof(Descriptor));
    for (std::size_t i = 0; i < keypoints.size(); ++i) {
      const Keypoint& k = keypoints[i];
      const std::int8_t* pairs = pattern.data() + static_cast<std::size_t>(k.angle_bin) * kOrbPairs * 4;
      Descriptor expected;
      for (int j = 0; j < kOrbPairs; ++j) {
        const Image& img = levels[k.level];
        const std::int8_t* p = pairs + 4 * j;
        if (img.at(k.x + p[0], k.y + p[1]) < img.at(k.x + p[2], k.y + p[3]))
          expected.bytes[static_cast<std::size_t>(j / 8)] |= static_cast<std::uint8_t>(1u << (j % 8));
      }
      ASSERT_EQ(out[i].bytes, expected.bytes) << bins << " bins, keypoint (" << k.x << ", " << k.y
                                              << ") level " << int{k.level} << " bin " << int{k.angle_bin};
    }
  }
}

}  // namespace
}  // namespace porta
