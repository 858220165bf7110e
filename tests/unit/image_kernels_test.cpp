// The cpu backend's image kernels (DESIGN.md §3.1 rectify, §3.2 pyramid, §3.7 blur) against
// hand-worked values and against naive re-implementations written from the contracts.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
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

// ---- Helpers -------------------------------------------------------------------------------------

/// A pyramid buffer of `layout` with `image` copied into level 0 (other levels zero).
std::unique_ptr<Buffer> upload_level0(Backend& backend, const PyramidLayout& layout, const Image& image) {
  auto buffer = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  const Plane& level0 = layout.levels[0];
  for (int y = 0; y < image.height(); ++y)
    backend.upload(
        *buffer, static_cast<std::size_t>(level0.offset_bytes + static_cast<std::int64_t>(y) * level0.pitch),
        image.row(y), static_cast<std::size_t>(image.width()));
  return buffer;
}

std::vector<std::uint8_t> download_all(Backend& backend, const Buffer& buffer) {
  std::vector<std::uint8_t> bytes(buffer.size_bytes());
  backend.download(buffer, 0, bytes.data(), bytes.size());
  return bytes;
}

/// Byte-for-byte comparison that names the first differing pixel.
void expect_same_image(const Image& actual, const Image& expected, const std::string& what) {
  ASSERT_EQ(actual.width(), expected.width()) << what;
  ASSERT_EQ(actual.height(), expected.height()) << what;
  for (int y = 0; y < expected.height(); ++y)
    for (int x = 0; x < expected.width(); ++x)
      if (actual.at(x, y) != expected.at(x, y)) {
        FAIL() << what << ": first difference at (" << x << ", " << y << "): got " << int(actual.at(x, y))
               << ", expected " << int(expected.at(x, y));
      }
}

// ---- Rectify (§3.1) ------------------------------------------------------------------------------

/// Runs rectify of `src` (uploaded with its own pitch) through `map_q5`, into a destination of
/// `dst_w` x `dst_h` placed at a non-zero offset with a padded pitch, and returns it packed.
Image run_rectify(cpu::CpuBackend& backend, const Image& src, const std::vector<std::int32_t>& map_q5,
                  int dst_w, int dst_h) {
  auto src_buffer = backend.allocate(src.size_bytes());
  backend.upload(*src_buffer, 0, src.data(), src.size_bytes());
  const Plane src_plane{0, src.width(), src.height(), src.pitch_bytes()};

  auto map_buffer = backend.allocate(map_q5.size() * sizeof(std::int32_t));
  backend.upload(*map_buffer, 0, map_q5.data(), map_q5.size() * sizeof(std::int32_t));

  const Plane dst_plane{96, dst_w, dst_h, dst_w + 5};
  auto dst_buffer = backend.allocate(static_cast<std::size_t>(96 + dst_plane.pitch * dst_h));
  backend.rectify(*src_buffer, src_plane, *map_buffer, *dst_buffer, dst_plane);

  PyramidLayout one;
  one.levels = {dst_plane};
  return test::download_levels(backend, *dst_buffer, one)[0];
}

/// Map whose destination pixel (x, y) samples source (x + dx_q5 / 32, y + dy_q5 / 32).
std::vector<std::int32_t> translation_map(int w, int h, int dx_q5, int dy_q5) {
  std::vector<std::int32_t> map;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      map.push_back(x * 32 + dx_q5);
      map.push_back(y * 32 + dy_q5);
    }
  return map;
}

TEST(Rectify, IdentityMapReproducesTheImage) {
  cpu::CpuBackend backend(2);
  const Image src = test::random_image(37, 23, 11, 41);  // padded pitch
  const Image out = run_rectify(backend, src, translation_map(37, 23, 0, 0), 37, 23);
  expect_same_image(out, Image::copy_of(src.view()), "identity rectify");
}

// dst(x, y) = src(x - 1, y): column 0 samples x = -1, outside the image, and reads 0 (not a
// replicated border). The map's x0 = -32 >> 5 = -1 also pins the floor shift on negatives.
TEST(Rectify, WholePixelShiftMovesTheImageAndZerosEnter) {
  cpu::CpuBackend backend(2);
  const Image src = test::random_image(19, 7, 3);
  Image expected(19, 7);
  for (int y = 0; y < 7; ++y)
    for (int x = 1; x < 19; ++x) expected.at(x, y) = src.at(x - 1, y);
  expect_same_image(run_rectify(backend, src, translation_map(19, 7, -32, 0), 19, 7), expected,
                    "shift right");

  // Shifting up by one row: the last row samples y = 7, below the image.
  Image expected_up(19, 7);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 19; ++x) expected_up.at(x, y) = src.at(x, y + 1);
  expect_same_image(run_rectify(backend, src, translation_map(19, 7, 0, 32), 19, 7), expected_up, "shift up");
}

// Half-pixel weights: fx = 16 gives two taps of 16 * 32 = 512.
//   [10 21] at (0.5, 0):     (512 * 10 + 512 * 21 + 512) >> 10 = 16384 >> 10 = 16  (15.5 rounds up)
//   [10 20; 30 41] at (0.5, 0.5): (256 * (10 + 20 + 30 + 41) + 512) >> 10 = 26368 >> 10 = 25 (25.25)
TEST(Rectify, HalfPixelGivesTheRoundedAverage) {
  cpu::CpuBackend backend(2);
  Image pair(2, 1);
  pair.at(0, 0) = 10;
  pair.at(1, 0) = 21;
  EXPECT_EQ(run_rectify(backend, pair, {16, 0}, 1, 1).at(0, 0), 16);

  Image quad(2, 2);
  quad.at(0, 0) = 10;
  quad.at(1, 0) = 20;
  quad.at(0, 1) = 30;
  quad.at(1, 1) = 41;
  EXPECT_EQ(run_rectify(backend, quad, {16, 16}, 1, 1).at(0, 0), 25);
}

// A 1x1 image of 200:
//   (-0.5, 0): x0 = -16 >> 5 = -1, fx = 16: 512 * 0 + 512 * 200 + 512 = 102912 >> 10 = 100
//   (0, -0.25): y0 = -8 >> 5 = -1, fy = 24: 32 * 8 * 0 + 32 * 24 * 200 + 512 = 154112 >> 10 = 150
//   (0.75, 0): fx = 24: 8 * 32 * 200 + 24 * 32 * 0 + 512 = 51712 >> 10 = 50
//   (1000, 5) and (-3, -2): every tap outside: 0
TEST(Rectify, TapsOutsideTheImageReadZero) {
  cpu::CpuBackend backend(2);
  const Image one = test::flat_image(1, 1, 200);
  const std::vector<std::int32_t> map = {-16, 0, 0, -8, 24, 0, 1000 * 32, 5 * 32, -3 * 32, -2 * 32};
  const Image out = run_rectify(backend, one, map, 5, 1);
  EXPECT_EQ(out.at(0, 0), 100);
  EXPECT_EQ(out.at(1, 0), 150);
  EXPECT_EQ(out.at(2, 0), 50);
  EXPECT_EQ(out.at(3, 0), 0);
  EXPECT_EQ(out.at(4, 0), 0);
}

// Random maps that wander outside the source, against a naive bilinear written with explicit
// floor division and 64-bit sums.
TEST(Rectify, RandomMapsMatchANaiveBilinear) {
  cpu::CpuBackend backend(2);
  const Image src = test::random_image(29, 17, 5, 33);
  const int dst_w = 31, dst_h = 13;
  const Image noise = test::random_image(dst_w * 2, dst_h, 77);
  std::vector<std::int32_t> map;
  for (int y = 0; y < dst_h; ++y)
    for (int x = 0; x < dst_w; ++x) {
      // Coordinates in [-2, 32) x [-2, 20): some taps fall off every side.
      map.push_back((noise.at(2 * x, y) * 34 * 32) / 256 - 64 + (x & 31));
      map.push_back((noise.at(2 * x + 1, y) * 22 * 32) / 256 - 64 + (y & 31));
    }
  Image expected(dst_w, dst_h);
  auto pixel = [&](std::int64_t x, std::int64_t y) -> std::int64_t {
    return (x >= 0 && y >= 0 && x < src.width() && y < src.height()) ? src.at(int(x), int(y)) : 0;
  };
  for (int y = 0; y < dst_h; ++y)
    for (int x = 0; x < dst_w; ++x) {
      const std::int64_t xq = map[2 * (y * dst_w + x)], yq = map[2 * (y * dst_w + x) + 1];
      const std::int64_t fx = ((xq % 32) + 32) % 32, fy = ((yq % 32) + 32) % 32;
      const std::int64_t x0 = (xq - fx) / 32, y0 = (yq - fy) / 32;
      std::int64_t sum = 512;
      for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 2; ++a) sum += (a ? fx : 32 - fx) * (b ? fy : 32 - fy) * pixel(x0 + a, y0 + b);
      expected.at(x, y) = static_cast<std::uint8_t>(sum / 1024);
    }
  expect_same_image(run_rectify(backend, src, map, dst_w, dst_h), expected, "random map");
}

// ---- Pyramid (§3.2) ------------------------------------------------------------------------------

/// Builds the pyramid of `image` with the given level sizes and returns every level.
std::vector<Image> run_pyramid(cpu::CpuBackend& backend, const Image& image, const Sizes& sizes,
                               int level0_pitch = 0) {
  const PyramidLayout layout = PyramidLayout::make(sizes, 1, level0_pitch);
  const ResizeTables tables = build_resize_tables(sizes);
  auto pyramid = upload_level0(backend, layout, image);
  auto table = backend.allocate(std::max<std::size_t>(1, tables.packed.size() * sizeof(std::int32_t)));
  if (!tables.packed.empty())
    backend.upload(*table, 0, tables.packed.data(), tables.packed.size() * sizeof(std::int32_t));
  backend.build_pyramid(*pyramid, layout, *table, tables.level_offset);
  return test::download_levels(backend, *pyramid, layout);
}

// Weights of each axis sum to 2048, so a flat v gives (v * 2^22 + 2^21) >> 22 = v everywhere.
TEST(Pyramid, FlatImageStaysFlatAtEveryLevel) {
  cpu::CpuBackend backend(2);
  for (const std::uint8_t v : {std::uint8_t{0}, std::uint8_t{1}, std::uint8_t{173}, std::uint8_t{255}}) {
    const Sizes sizes = pyramid_level_sizes(640, 480, 8, 1.2);
    const auto levels = run_pyramid(backend, test::flat_image(640, 480, v), sizes);
    for (std::size_t n = 0; n < levels.size(); ++n)
      expect_same_image(levels[n], test::flat_image(sizes[n].first, sizes[n].second, v),
                        "flat " + std::to_string(v) + " level " + std::to_string(n));
  }
}

// 4x1 -> 3x1 of [10 40 100 200]. Source x = (j + 0.5) * 4/3 - 0.5:
//   j = 0: x = 0.1667: x0 = 0, w1 = round(341.3) = 341: 1707*10 + 341*40 = 30710;
//          (2048 * 30710 + 2^21) >> 22 = floor(14.995 + 0.5) = 15
//   j = 1: x = 1.5:    x0 = 1, w1 = 1024: 1024*40 + 1024*100 = 143360 = 70 * 2048 -> 70
//   j = 2: x = 2.8333: x0 = 2, w1 = round(1706.7) = 1707: 341*100 + 1707*200 = 375500;
//          375500 / 2048 = 183.35 -> 183
// The single row maps to y0 = 0 with w1 = 0 (y1 is clamped to 0). Transposed, the same values
// come out of the row weights.
TEST(Pyramid, FourToThreeDownsampleMatchesHandWorkedValues) {
  cpu::CpuBackend backend(2);
  const Sizes sizes = {{4, 1}, {3, 1}};
  const ResizeTables tables = build_resize_tables(sizes);
  ASSERT_EQ(tables.cols[0].src0, (std::vector<std::int32_t>{0, 1, 2}));
  ASSERT_EQ(tables.cols[0].w1, (std::vector<std::int32_t>{341, 1024, 1707}));

  Image row(4, 1);
  const std::uint8_t values[4] = {10, 40, 100, 200};
  for (int x = 0; x < 4; ++x) row.at(x, 0) = values[x];
  const auto levels = run_pyramid(backend, row, sizes);
  EXPECT_EQ(levels[1].at(0, 0), 15);
  EXPECT_EQ(levels[1].at(1, 0), 70);
  EXPECT_EQ(levels[1].at(2, 0), 183);

  Image column(1, 4);
  for (int y = 0; y < 4; ++y) column.at(0, y) = values[y];
  const auto column_levels = run_pyramid(backend, column, {{1, 4}, {1, 3}});
  EXPECT_EQ(column_levels[1].at(0, 0), 15);
  EXPECT_EQ(column_levels[1].at(0, 1), 70);
  EXPECT_EQ(column_levels[1].at(0, 2), 183);
}

TEST(Pyramid, LevelsMatchANaiveCascadeOnRandomImages) {
  cpu::CpuBackend backend(2);
  struct Case {
    int width, height, levels, level0_pitch;
    double scale;
  };
  const Case cases[] = {
      {1, 1, 4, 0, 1.2},        // every level 1x1
      {7, 5, 5, 0, 1.2},        // tiny odd sizes
      {7, 5, 12, 9, 1.2},       // down to 1-pixel levels, odd level-0 pitch
      {640, 480, 8, 643, 1.2},  // the default, odd level-0 pitch
      {333, 97, 4, 0, 2.0},     // halving: x0 and w1 = 1024 on every column
  };
  for (const Case& c : cases) {
    const Sizes sizes = pyramid_level_sizes(c.width, c.height, c.levels, c.scale);
    const Image image = test::random_image(c.width, c.height, 1000 + static_cast<std::uint64_t>(c.width));
    const auto actual = run_pyramid(backend, image, sizes, c.level0_pitch);
    const auto expected = test::contract_pyramid(image, sizes);
    ASSERT_EQ(actual.size(), expected.size());
    for (std::size_t n = 0; n < actual.size(); ++n)
      expect_same_image(
          actual[n], expected[n],
          std::to_string(c.width) + "x" + std::to_string(c.height) + " level " + std::to_string(n));
  }
}

// ---- Blur (§3.7) ---------------------------------------------------------------------------------

/// Blurs every level of a pyramid buffer whose levels hold `images`, and returns the result.
std::vector<Image> run_blur(cpu::CpuBackend& backend, const std::vector<Image>& images,
                            int level0_pitch = 0) {
  Sizes sizes;
  for (const Image& img : images) sizes.emplace_back(img.width(), img.height());
  const PyramidLayout layout = PyramidLayout::make(sizes, 1, level0_pitch);
  auto pyramid = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  for (std::size_t n = 0; n < images.size(); ++n)
    for (int y = 0; y < images[n].height(); ++y)
      backend.upload(*pyramid,
                     static_cast<std::size_t>(layout.levels[n].offset_bytes +
                                              static_cast<std::int64_t>(y) * layout.levels[n].pitch),
                     images[n].row(y), static_cast<std::size_t>(images[n].width()));
  auto blurred = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  backend.blur(*pyramid, layout, *blurred, build_blur_taps());
  return test::download_levels(backend, *blurred, layout);
}

/// Mirror without the repeat (reflect-101) by stepping, written independently of reflect101().
int mirror(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * (n - 1) - i;
  return i;
}

/// Naive blur straight from the formula: every output pixel recomputes its 7 horizontal sums.
Image naive_blur(const Image& src, const std::array<std::int32_t, 7>& taps) {
  Image out(src.width(), src.height());
  for (int y = 0; y < src.height(); ++y)
    for (int x = 0; x < src.width(); ++x) {
      std::int64_t sum = 0;
      for (int ky = -3; ky <= 3; ++ky) {
        std::int64_t h = 0;
        for (int kx = -3; kx <= 3; ++kx)
          h += taps[kx + 3] * src.at(mirror(x + kx, src.width()), mirror(y + ky, src.height()));
        sum += taps[ky + 3] * h;
      }
      out.at(x, y) = static_cast<std::uint8_t>((sum + 32768) / 65536);
    }
  return out;
}

// Each pass multiplies a flat v by 256: (256 * 256 * v + 2^15) >> 16 = v. Also on 1-pixel levels,
// where reflect-101 folds all 7 taps onto the one pixel.
TEST(Blur, FlatStaysFlat) {
  cpu::CpuBackend backend(2);
  for (const std::uint8_t v : {std::uint8_t{1}, std::uint8_t{137}, std::uint8_t{255}}) {
    const std::vector<Image> images = {test::flat_image(64, 48, v), test::flat_image(1, 1, v),
                                       test::flat_image(2, 3, v), test::flat_image(9, 1, v)};
    const auto out = run_blur(backend, images);
    for (std::size_t n = 0; n < images.size(); ++n)
      expect_same_image(out[n], images[n], "flat " + std::to_string(v) + " level " + std::to_string(n));
  }
}

// taps = {18, 34, 49, 54, 49, 34, 18} (asserted below). A 255 impulse at (7, 7) gives
// out(7 + dx, 7 + dy) = (t[dx] * t[dy] * 255 + 2^15) >> 16, e.g. at the centre
// (54 * 54 * 255 + 32768) >> 16 = (743580 + 32768) >> 16 = 776348 >> 16 = 11 (11.85 rounds down
// because the rounding is applied once, at the end), and 0 farther than 3 px.
TEST(Blur, ImpulseGivesTheOuterProductOfTheTaps) {
  cpu::CpuBackend backend(2);
  const auto taps = build_blur_taps();
  ASSERT_EQ(taps, (std::array<std::int32_t, 7>{18, 34, 49, 54, 49, 34, 18}));
  Image impulse(15, 15);
  impulse.at(7, 7) = 255;
  const Image out = run_blur(backend, {impulse})[0];
  EXPECT_EQ(out.at(7, 7), 11);
  EXPECT_EQ(out.at(4, 4), 1);  // (18 * 18 * 255 + 32768) >> 16 = 115388 >> 16 = 1
  for (int y = 0; y < 15; ++y)
    for (int x = 0; x < 15; ++x) {
      const int dx = x - 7, dy = y - 7;
      const bool inside = dx >= -3 && dx <= 3 && dy >= -3 && dy <= 3;
      const int expected = inside ? (taps[dx + 3] * taps[dy + 3] * 255 + 32768) >> 16 : 0;
      EXPECT_EQ(out.at(x, y), expected) << "at (" << x << ", " << y << ")";
    }
}

// A vertical line of 64 at column 7: the vertical pass sees a flat column, so
// out(7 + d) = (t[d] * 256 * 64 + 2^15) >> 16 = round-half-up(t[d] / 4):
//   18 / 4 = 4.5 -> 5, 34 / 4 = 8.5 -> 9, 49 / 4 = 12.25 -> 12, 54 / 4 = 13.5 -> 14.
// Three of the four are exact halves, which pins "+ 2^15" (half up) rather than any other bias.
TEST(Blur, ExactHalvesRoundUp) {
  cpu::CpuBackend backend(2);
  Image line(15, 6);
  for (int y = 0; y < 6; ++y) line.at(7, y) = 64;
  const Image out = run_blur(backend, {line})[0];
  const int expected[15] = {0, 0, 0, 0, 5, 9, 12, 14, 12, 9, 5, 0, 0, 0, 0};
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 15; ++x) EXPECT_EQ(out.at(x, y), expected[x]) << "at (" << x << ", " << y << ")";
}

TEST(Blur, ReflectBordersMatchANaiveBlurOnRandomLevels) {
  cpu::CpuBackend backend(2);
  const Sizes sizes = {{37, 29}, {1, 1}, {2, 3}, {3, 2}, {1, 7}, {7, 1}, {4, 4}, {64, 5}};
  std::vector<Image> images;
  for (std::size_t n = 0; n < sizes.size(); ++n)
    images.push_back(test::random_image(sizes[n].first, sizes[n].second, 500 + n));
  const auto out = run_blur(backend, images, 41);  // odd level-0 pitch
  const auto taps = build_blur_taps();
  for (std::size_t n = 0; n < images.size(); ++n)
    expect_same_image(out[n], naive_blur(images[n], taps),
                      std::to_string(sizes[n].first) + "x" + std::to_string(sizes[n].second));
}

TEST(Blur, RejectsTapsThatDoNotSumTo256) {
  cpu::CpuBackend backend(1);
  const PyramidLayout layout = PyramidLayout::make({{8, 8}}, 1);
  auto pyramid = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  auto blurred = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  EXPECT_THROW(backend.blur(*pyramid, layout, *blurred, {0, 0, 0, 255, 0, 0, 0}), BackendError);
  EXPECT_THROW(backend.blur(*pyramid, layout, *blurred, {-1, 0, 0, 258, 0, 0, -1}), BackendError);
}

// ---- Thread-count independence -------------------------------------------------------------------

// The whole image chain (rectify, pyramid, blur) on one thread and on two gives the same bytes,
// padding included.
TEST(ImageKernels, ResultsDoNotDependOnTheThreadCount) {
  const Image src = test::textured_image(640, 480, 9);
  const Sizes sizes = pyramid_level_sizes(640, 480, 8, 1.2);
  const PyramidLayout layout = PyramidLayout::make(sizes, 1);
  const ResizeTables tables = build_resize_tables(sizes);
  // A mild rotation-like warp in Q5: x' = x + y / 16, y' = y - x / 16 (both can leave the image).
  std::vector<std::int32_t> map;
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x) {
      map.push_back(x * 32 + y * 2);
      map.push_back(y * 32 - x * 2);
    }

  auto run_chain = [&](int threads) {
    cpu::CpuBackend backend(threads);
    auto src_buffer = backend.allocate(src.size_bytes());
    backend.upload(*src_buffer, 0, src.data(), src.size_bytes());
    auto map_buffer = backend.allocate(map.size() * sizeof(std::int32_t));
    backend.upload(*map_buffer, 0, map.data(), map.size() * sizeof(std::int32_t));
    auto table = backend.allocate(tables.packed.size() * sizeof(std::int32_t));
    backend.upload(*table, 0, tables.packed.data(), tables.packed.size() * sizeof(std::int32_t));
    auto pyramid = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
    auto blurred = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
    backend.rectify(*src_buffer, {0, 640, 480, src.pitch_bytes()}, *map_buffer, *pyramid, layout.levels[0]);
    backend.build_pyramid(*pyramid, layout, *table, tables.level_offset);
    backend.blur(*pyramid, layout, *blurred, build_blur_taps());
    return std::make_pair(download_all(backend, *pyramid), download_all(backend, *blurred));
  };
  const auto one = run_chain(1);
  const auto two = run_chain(2);
  EXPECT_TRUE(one.first == two.first) << "pyramids differ";
  EXPECT_TRUE(one.second == two.second) << "blurred pyramids differ";
}

}  // namespace
}  // namespace porta
