// Detection kernels of the cpu backend (DESIGN.md §3.3-3.5): FAST CRF, cell culling, PFA and
// compaction, against hand-worked cases and naive re-implementations written here.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "porta/tables.hpp"
#include "support/test_images.hpp"
#include "unit/detect_runners.hpp"
#include "unit/kernel_test_buffers.hpp"

namespace porta {
namespace {

using cpu::CpuBackend;
using Responses = std::vector<std::vector<std::uint16_t>>;  // per level, row-major width x height

using test::upload_vector;

/// Runs fast_crf on level images given one by one (no resampling involved), over a response
/// buffer full of stale 0xA5A5 values, and returns the responses without padding.
Responses run_fast(CpuBackend& backend, const std::vector<Image>& levels, int min_arc, int max_arc,
                   FastParams params) {
  return test::run_fast_crf(backend, levels, build_fast_lut(min_arc, max_arc), params);
}

Responses run_fast(CpuBackend& backend, const Image& image, int min_arc, int max_arc, FastParams params) {
  return run_fast(backend, std::vector<Image>{Image::copy_of(image.view())}, min_arc, max_arc, params);
}

std::uint16_t at(const std::vector<std::uint16_t>& plane, int width, int x, int y) {
  return plane[static_cast<std::size_t>(y) * width + x];
}

int count_nonzero(const std::vector<std::uint16_t>& plane) {
  return static_cast<int>(std::count_if(plane.begin(), plane.end(), [](std::uint16_t r) { return r != 0; }));
}

// The naive FAST: the radius-3 Bresenham circle written out clockwise from 12 o'clock, the arc
// found by trying every start position, no lookup table.
std::uint16_t naive_fast(const Image& img, int x, int y, int eps, int edge, int min_arc, int max_arc) {
  if (x < edge || y < edge || x >= img.width() - edge || y >= img.height() - edge) return 0;
  static constexpr int kDx[16] = {0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3, -3, -3, -2, -1};
  static constexpr int kDy[16] = {-3, -3, -2, -1, 0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3};
  const int c = img.at(x, y);
  std::array<bool, 16> bright{}, dark{};
  int sum = 0;
  for (int i = 0; i < 16; ++i) {
    const int p = img.at(x + kDx[i], y + kDy[i]);
    bright[i] = p > c + eps;
    dark[i] = p < c - eps;
    sum += p > c ? p - c : c - p;
  }
  const auto longest_run = [](const std::array<bool, 16>& set) {
    int best = 0;
    for (int start = 0; start < 16; ++start) {
      int len = 0;
      while (len < 16 && set[(start + len) % 16]) ++len;
      best = std::max(best, len);
    }
    return best;
  };
  const auto passes = [&](const std::array<bool, 16>& set) {
    const int run = longest_run(set);
    return run >= min_arc && run <= max_arc;
  };
  return (passes(bright) || passes(dark)) ? static_cast<std::uint16_t>(sum) : 0;
}

// ---- FAST CRF (§3.3) ---------------------------------------------------------------------------

// A 50-valued square fills x >= 32, y >= 32 of a 200-valued 64 x 64 image. At the square's corner
// pixel (32, 32) the circle offsets with dx < 0 or dy < 0 lie outside the square: indices 9..15
// and 0..3, a circular run of 11 bright pixels (200 > 50 + 20), within [9, 13]. The other five
// (indices 4..8) equal the centre. Response 11 * 150 = 1650, the image's unique maximum, since
// no other pixel sees 11 circle pixels on the other side of the square's outline.
TEST(FastCrf, DarkSquareCornerRespondsWithItsElevenPixelArc) {
  CpuBackend backend(2);
  Image img = test::flat_image(64, 64, 200);
  for (int y = 32; y < 64; ++y)
    for (int x = 32; x < 64; ++x) img.at(x, y) = 50;
  const auto r = run_fast(backend, img, 9, 13, FastParams{20, 19})[0];

  EXPECT_EQ(at(r, 64, 32, 32), 1650);
  // (32, 33): indices 9..15 and 0..2 are outside, a run of 10 -> 1500.
  EXPECT_EQ(at(r, 64, 32, 33), 1500);
  // Straight edges see runs of 7: (32, 40) just inside the left side, (31, 40) just outside it,
  // (40, 32) just inside the top side.
  EXPECT_EQ(at(r, 64, 32, 40), 0);
  EXPECT_EQ(at(r, 64, 31, 40), 0);
  EXPECT_EQ(at(r, 64, 40, 32), 0);
  // (31, 31) sees only 3 dark pixels (indices 5..7).
  EXPECT_EQ(at(r, 64, 31, 31), 0);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      if (std::max(std::abs(x - 32), std::abs(y - 32)) > 3) {
        EXPECT_EQ(at(r, 64, x, y), 0) << x << "," << y;
      }
      if (x != 32 || y != 32) {
        EXPECT_LT(at(r, 64, x, y), 1650) << x << "," << y;
      }
    }
}

// One pixel different from a flat background: all 16 circle pixels pass, a run of 16. Bounded
// rectification (Pmax 13) rejects it; classic FAST (Pmax 16) accepts it with 16 * |dot - bg|.
// Pixels whose circle crosses the dot see a single differing pixel and stay 0.
TEST(FastCrf, IsolatedDotIsRejectedByPmax13AndAcceptedByPmax16) {
  CpuBackend backend(2);
  for (const int dot : {130, 60}) {
    Image img = test::flat_image(64, 64, 100);
    img.at(32, 32) = static_cast<std::uint8_t>(dot);
    const auto bounded = run_fast(backend, img, 9, 13, FastParams{20, 19})[0];
    EXPECT_EQ(count_nonzero(bounded), 0) << "dot " << dot;

    const auto classic = run_fast(backend, img, 9, 16, FastParams{20, 19})[0];
    EXPECT_EQ(at(classic, 64, 32, 32), 16 * std::abs(dot - 100)) << "dot " << dot;  // 480, 640
    EXPECT_EQ(count_nonzero(classic), 1) << "dot " << dot;
  }
}

// The comparisons are strict: a dot exactly eps above the background (120 vs 100 + 20) makes no
// mask bit; one level more (121) makes all 16, response 16 * 21 = 336.
TEST(FastCrf, DifferenceEqualToThresholdIsNotACorner) {
  CpuBackend backend(2);
  Image img = test::flat_image(64, 64, 100);
  img.at(32, 32) = 120;
  EXPECT_EQ(count_nonzero(run_fast(backend, img, 9, 16, FastParams{20, 19})[0]), 0);
  img.at(32, 32) = 121;
  EXPECT_EQ(at(run_fast(backend, img, 9, 16, FastParams{20, 19})[0], 64, 32, 32), 336);
}

// The response buffer starts full of 0xA5A5 (a previous frame); every pixel must be rewritten.
TEST(FastCrf, FlatImageGivesZeroEverywhere) {
  CpuBackend backend(2);
  for (const std::uint8_t v : {0, 128, 255}) {
    const auto r = run_fast(backend, test::flat_image(80, 60, v), 9, 16, FastParams{20, 19})[0];
    EXPECT_EQ(count_nonzero(r), 0) << "value " << int{v};
  }
}

TEST(FastCrf, PixelsCloserThanEdgeToTheBorderAreZero) {
  CpuBackend backend(2);
  const Image img = test::random_image(64, 48, 7);
  for (const int edge : {19, 5}) {
    const auto r = run_fast(backend, img, 9, 16, FastParams{5, edge})[0];
    int interior_corners = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x) {
        const bool inside = x >= edge && y >= edge && x < 64 - edge && y < 48 - edge;
        if (!inside) {
          EXPECT_EQ(at(r, 64, x, y), 0) << "edge " << edge << " at " << x << "," << y;
        }
        if (inside && at(r, 64, x, y) != 0) ++interior_corners;
      }
    EXPECT_GT(interior_corners, 0) << "edge " << edge << ": the image should have corners";
  }
}

TEST(FastCrf, MatchesNaiveImplementationByteForByte) {
  CpuBackend backend(2);
  std::vector<std::vector<Image>> cases;
  // Single levels, including sides below 2 * 19 + 1 (no pixel far enough from the border), exactly
  // 39 (one candidate pixel) and an image with a wide row pitch.
  for (const auto& [w, h] :
       std::vector<std::pair<int, int>>{{64, 64}, {37, 41}, {100, 23}, {39, 39}, {38, 38}, {1, 1}, {131, 45}})
    cases.push_back({test::random_image(w, h, static_cast<std::uint64_t>(w * 1000 + h))});
  cases.push_back({test::textured_image(97, 70, 3, 160)});
  // A pyramid's worth of unrelated textured levels.
  std::vector<Image> levels;
  std::uint64_t seed = 11;
  for (const auto& [w, h] : pyramid_level_sizes(160, 120, 5, 1.2))
    levels.push_back(test::textured_image(w, h, seed++));
  cases.push_back(std::move(levels));

  int corners = 0;
  for (const auto& [min_arc, max_arc] : std::vector<std::pair<int, int>>{{9, 13}, {9, 16}, {12, 16}})
    for (const FastParams params : {FastParams{20, 19}, FastParams{8, 3}}) {
      for (const auto& c : cases) {
        const auto got = run_fast(backend, c, min_arc, max_arc, params);
        for (std::size_t n = 0; n < c.size(); ++n) {
          const Image& img = c[n];
          for (int y = 0; y < img.height(); ++y)
            for (int x = 0; x < img.width(); ++x) {
              const std::uint16_t want =
                  naive_fast(img, x, y, params.threshold, params.edge, min_arc, max_arc);
              ASSERT_EQ(at(got[n], img.width(), x, y), want)
                  << img.width() << "x" << img.height() << " level " << n << " at " << x << "," << y
                  << " arc [" << min_arc << "," << max_arc << "] eps " << params.threshold << " edge "
                  << params.edge;
              corners += want != 0;
            }
        }
      }
    }
  EXPECT_GT(corners, 1000);  // the comparison covered real corners, not only zeros
}

TEST(FastCrf, EdgeBelowTheCircleRadiusIsRefused) {
  CpuBackend backend(2);
  EXPECT_THROW(run_fast(backend, test::flat_image(16, 16, 0), 9, 13, FastParams{20, 2}), BackendError);
}

// ---- Culling (§3.4) ----------------------------------------------------------------------------

std::string str(const Keypoint& k) {
  return "{x " + std::to_string(k.x) + ", y " + std::to_string(k.y) + ", r " + std::to_string(k.response) +
         ", level " + std::to_string(k.level) + ", bin " + std::to_string(k.angle_bin) + "}";
}

Keypoint kp(int x, int y, int response, int level) {
  Keypoint k;
  k.x = static_cast<std::uint16_t>(x);
  k.y = static_cast<std::uint16_t>(y);
  k.response = static_cast<std::uint16_t>(response);
  k.level = static_cast<std::uint8_t>(level);
  return k;
}

/// Uploads response planes into a response layout whose padding (and the gaps between levels)
/// hold 0xFFFF, larger than any response, so reading outside a level shows; runs cull_cells over
/// a cell array full of 0xFF bytes and returns it.
std::vector<Keypoint> run_cull(CpuBackend& backend, const std::vector<std::pair<int, int>>& sizes,
                               const Responses& planes, const CellLayout& cells) {
  return test::run_cull_cells(backend, sizes, planes, cells);
}

void set(std::vector<std::uint16_t>& plane, int width, int x, int y, int value) {
  plane[static_cast<std::size_t>(y) * width + x] = static_cast<std::uint16_t>(value);
}

// 16 x 16 level, 8 x 8 cells (2 x 2).
//   cell (0,0): 500 at (7,2), (5,2) and (1,6), 499 at (0,0) -> row 2 beats row 6, then column 5
//               beats column 7: (5,2).
//   cell (1,0): 300 at (15,0) and (8,7) -> the smaller row wins although its column is larger.
//   cell (0,1): nothing -> an all-zero record.
//   cell (1,1): 7 at (12,12).
TEST(Culling, TiesGoToSmallerRowThenColumn) {
  CpuBackend backend(2);
  const std::vector<std::pair<int, int>> sizes{{16, 16}};
  const CellLayout cells = build_cell_layout(sizes, 8, 8, 1.2);
  ASSERT_EQ(cells.total_cells, 4);
  Responses planes{std::vector<std::uint16_t>(16 * 16, 0)};
  set(planes[0], 16, 7, 2, 500);
  set(planes[0], 16, 5, 2, 500);
  set(planes[0], 16, 1, 6, 500);
  set(planes[0], 16, 0, 0, 499);
  set(planes[0], 16, 15, 0, 300);
  set(planes[0], 16, 8, 7, 300);
  set(planes[0], 16, 12, 12, 7);
  const auto got = run_cull(backend, sizes, planes, cells);
  EXPECT_EQ(str(got[0]), str(kp(5, 2, 500, 0)));
  EXPECT_EQ(str(got[1]), str(kp(15, 0, 300, 0)));
  EXPECT_EQ(str(got[2]), str(Keypoint{}));
  EXPECT_EQ(str(got[3]), str(kp(12, 12, 7, 0)));
}

// A 20 x 13 level in 8 x 8 cells: 3 columns (8, 8, 4 px) and 2 rows (8, 5 px). The padding
// columns 20.. hold 0xFFFF, so a cell that reads past the level's width reports x >= 20.
TEST(Culling, PartialLastRowAndColumnStopAtTheLevelBorder) {
  CpuBackend backend(2);
  const std::vector<std::pair<int, int>> sizes{{20, 13}};
  const CellLayout cells = build_cell_layout(sizes, 8, 8, 1.2);
  ASSERT_EQ(cells.levels[0].cols, 3);
  ASSERT_EQ(cells.levels[0].rows, 2);
  Responses planes{std::vector<std::uint16_t>(20 * 13, 0)};
  set(planes[0], 20, 19, 12, 900);  // the level's last pixel, cell (2,1)
  set(planes[0], 20, 16, 8, 800);   // same cell, smaller
  set(planes[0], 20, 16, 0, 40);    // cell (2,0)
  set(planes[0], 20, 19, 7, 41);    // cell (2,0), larger
  set(planes[0], 20, 0, 12, 5);     // cell (0,1)
  const auto got = run_cull(backend, sizes, planes, cells);
  ASSERT_EQ(got.size(), 6u);
  EXPECT_EQ(str(got[0]), str(Keypoint{}));
  EXPECT_EQ(str(got[1]), str(Keypoint{}));
  EXPECT_EQ(str(got[2]), str(kp(19, 7, 41, 0)));
  EXPECT_EQ(str(got[3]), str(kp(0, 12, 5, 0)));
  EXPECT_EQ(str(got[4]), str(Keypoint{}));
  EXPECT_EQ(str(got[5]), str(kp(19, 12, 900, 0)));
}

// Every byte of an empty cell's record is zero (the buffer held 0xFF before).
TEST(Culling, EmptyCellGivesAllZeroRecord) {
  CpuBackend backend(2);
  const std::vector<std::pair<int, int>> sizes{{10, 10}, {5, 5}};
  const CellLayout cells = build_cell_layout(sizes, 4, 4, 2.0);  // 3 x 3 cells of 4, then 3 x 3 of 2
  ASSERT_EQ(cells.total_cells, 18);
  const Responses planes{std::vector<std::uint16_t>(100, 0), std::vector<std::uint16_t>(25, 0)};
  const auto got = run_cull(backend, sizes, planes, cells);
  const Keypoint zero{};
  for (int i = 0; i < cells.total_cells; ++i)
    EXPECT_EQ(std::memcmp(&got[static_cast<std::size_t>(i)], &zero, sizeof(Keypoint)), 0) << "cell " << i;
}

// Naive culling: walk each level column by column, bottom to top, and keep a pixel when it beats
// the cell's best by (response desc, row asc, column asc).
std::vector<Keypoint> naive_cull(const std::vector<std::pair<int, int>>& sizes, const Responses& planes,
                                 const CellLayout& cells) {
  std::vector<Keypoint> out(static_cast<std::size_t>(cells.total_cells));
  for (std::size_t n = 0; n < sizes.size(); ++n) {
    const auto [w, h] = sizes[n];
    const LevelCells& g = cells.levels[n];
    for (int x = 0; x < w; ++x)
      for (int y = h - 1; y >= 0; --y) {
        const int r = planes[n][static_cast<std::size_t>(y) * w + x];
        Keypoint& best = out[static_cast<std::size_t>(g.first_cell + (y / g.cell_h) * g.cols + x / g.cell_w)];
        const bool better =
            r > best.response || (r == best.response && r > 0 && (y < best.y || (y == best.y && x < best.x)));
        if (better) best = kp(x, y, r, static_cast<int>(n));
      }
  }
  return out;
}

TEST(Culling, MatchesNaiveCullingOnTableCellLayouts) {
  CpuBackend backend(2);
  std::mt19937 rng(5);
  for (const auto& [cw, ch] : std::vector<std::pair<int, int>>{{16, 16}, {16, 10}, {32, 32}, {7, 3}}) {
    const auto sizes = pyramid_level_sizes(150, 97, 6, 1.2);
    const CellLayout cells = build_cell_layout(sizes, cw, ch, 1.2);
    Responses planes;
    for (const auto& [w, h] : sizes) {
      // Mostly zeros, few distinct values, so that ties and empty cells are common.
      std::vector<std::uint16_t> plane(static_cast<std::size_t>(w) * h);
      for (auto& r : plane) r = (rng() % 4 == 0) ? static_cast<std::uint16_t>(1 + rng() % 5) : 0;
      planes.push_back(std::move(plane));
    }
    const auto got = run_cull(backend, sizes, planes, cells);
    const auto want = naive_cull(sizes, planes, cells);
    for (int i = 0; i < cells.total_cells; ++i)
      ASSERT_EQ(str(got[static_cast<std::size_t>(i)]), str(want[static_cast<std::size_t>(i)]))
          << "cell " << i << " with cells " << cw << "x" << ch;
  }
}

// ---- PFA (§3.5) --------------------------------------------------------------------------------

std::vector<Keypoint> run_pfa(CpuBackend& backend, const std::vector<Keypoint>& in, const PfaParams& params) {
  auto cells = upload_vector(backend, in);
  CellLayout layout;
  layout.total_cells = static_cast<int>(in.size());  // PFA sees only the dense array
  backend.pfa_filter(*cells, layout, params);
  std::vector<Keypoint> out(in.size());
  backend.download(*cells, 0, out.data(), out.size() * sizeof(Keypoint));
  return out;
}

// Scale 2: S = {65536, 131072, 262144}, a level-n pixel x lands on x * 2^n at level 0.
PfaParams scale2_params(int window = 3) { return PfaParams{build_level_scales_q16(3, 2.0), 64, 64, window}; }

void expect_survivors(const std::vector<Keypoint>& in, const std::vector<Keypoint>& out,
                      const std::vector<bool>& survives) {
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i)
    EXPECT_EQ(str(out[i]), str(survives[i] ? in[i] : Keypoint{})) << "cell " << i;
}

// a = level 0 (20,20) r 100 and b = level 1 (10,10) r 100 both land on L = (20,20):
// score 200 * 2 = 400. c = level 0 (21,20) r 300 scores 300 * 1 = 300 and lies in the 3 x 3
// window of (20,20): c falls, a and b stay. An empty cell between them stays empty.
TEST(Pfa, TwoLevelsAtOneLocationBeatAStrongerSingleNeighbour) {
  CpuBackend backend(2);
  const std::vector<Keypoint> in{kp(20, 20, 100, 0), Keypoint{}, kp(21, 20, 300, 0), kp(10, 10, 100, 1)};
  expect_survivors(in, run_pfa(backend, in, scale2_params()), {true, true, false, true});
}

// (20,20) r 100 and (22,20) r 500 are 2 apart: outside each other's 3 x 3 window, both stay;
// in a 5 x 5 window the weaker falls. (40,40) r 1 is far from both and always stays.
TEST(Pfa, KeypointsFartherApartThanTheWindowBothSurvive) {
  CpuBackend backend(2);
  const std::vector<Keypoint> in{kp(20, 20, 100, 0), kp(22, 20, 500, 0), kp(40, 40, 1, 0)};
  expect_survivors(in, run_pfa(backend, in, scale2_params(3)), {true, true, true});
  expect_survivors(in, run_pfa(backend, in, scale2_params(5)), {false, true, true});
}

// Only a strictly greater score rejects.
//   Pair 1: (20,20) r 150 and (21,21) r 150, diagonal neighbours, score 150 each.
//   Pair 2: L = (40,40) gets level 0 r 100 and level 2 (10,10) r 50: score 150 * 2 = 300;
//           (41,40) gets level 0 r 300: score 300.
// All five survive.
TEST(Pfa, EqualScoresBothSurvive) {
  CpuBackend backend(2);
  const std::vector<Keypoint> in{kp(20, 20, 150, 0), kp(21, 21, 150, 0), kp(40, 40, 100, 0),
                                 kp(10, 10, 50, 2), kp(41, 40, 300, 0)};
  expect_survivors(in, run_pfa(backend, in, scale2_params()), {true, true, true, true, true});
}

// L = (20,20) gets levels 0, 1 and 2 with r 10 each: score 30 * 3 = 90. (19,21) r 91 outscores it,
// so all three keypoints at L fall together.
TEST(Pfa, KeypointsSharingALocationFallTogether) {
  CpuBackend backend(2);
  const std::vector<Keypoint> in{kp(20, 20, 10, 0), kp(10, 10, 10, 1), kp(5, 5, 10, 2), kp(19, 21, 91, 0)};
  expect_survivors(in, run_pfa(backend, in, scale2_params()), {false, false, false, true});
}

// Scale 1.2: S[1] = round(1.2 * 65536) = 78643, one short of 1.2 exactly, so level-1 (10,10)
// lands on (786430 >> 16) = 11, not 12. There it joins level-0 (11,11) r 100: score 200 * 2 =
// 400, which rejects level-0 (12,12) r 300. (Had it landed on (12,12), that location would have
// scored 800 and rejected (11,11) instead.)
TEST(Pfa, ProjectionFloorsTheQ16Product) {
  CpuBackend backend(2);
  const PfaParams params{build_level_scales_q16(2, 1.2), 64, 64, 3};
  ASSERT_EQ(params.scales_q16[1], 78643);
  const std::vector<Keypoint> in{kp(11, 11, 100, 0), kp(10, 10, 100, 1), kp(12, 12, 300, 0)};
  expect_survivors(in, run_pfa(backend, in, params), {true, true, false});
}

// Level 0 is 61 wide. Level-1 (31,2) projects to (62,4), clamped to (60,4), where it joins
// level-0 (60,4) r 100: score 200 * 2 = 400, which rejects level-0 (59,4) r 300. Unclamped, the
// level-1 keypoint would sit 3 columns from (59,4) and (60,4) alone (100) would fall instead.
TEST(Pfa, ProjectionIsClampedToTheLevel0Image) {
  CpuBackend backend(2);
  PfaParams params = scale2_params();
  params.level0_width = 61;
  const std::vector<Keypoint> in{kp(60, 4, 100, 0), kp(31, 2, 100, 1), kp(59, 4, 300, 0)};
  expect_survivors(in, run_pfa(backend, in, params), {true, true, false});
}

// Naive PFA: a dense level-0 map of summed responses and a bitmask of levels, then a window scan
// for every keypoint.
std::vector<Keypoint> naive_pfa(const std::vector<Keypoint>& in, const PfaParams& p) {
  const int w = p.level0_width, h = p.level0_height;
  std::vector<std::uint32_t> sum(static_cast<std::size_t>(w) * h, 0), levels(sum.size(), 0);
  std::vector<std::pair<int, int>> where(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    if (in[i].response == 0) continue;
    const double s = p.scales_q16[in[i].level] / 65536.0;  // exact: a Q16 value in a double
    const int x = std::min(w - 1, static_cast<int>(std::floor(in[i].x * s)));
    const int y = std::min(h - 1, static_cast<int>(std::floor(in[i].y * s)));
    where[i] = {x, y};
    sum[static_cast<std::size_t>(y) * w + x] += in[i].response;
    levels[static_cast<std::size_t>(y) * w + x] |= 1u << in[i].level;
  }
  const auto score = [&](int x, int y) {
    const std::size_t k = static_cast<std::size_t>(y) * w + x;
    return sum[k] * static_cast<std::uint32_t>(__builtin_popcount(levels[k]));
  };
  std::vector<Keypoint> out = in;
  const int half = p.window / 2;
  for (std::size_t i = 0; i < in.size(); ++i) {
    if (in[i].response == 0) continue;
    const auto [x, y] = where[i];
    bool beaten = false;
    for (int yy = y - half; yy <= y + half; ++yy)
      for (int xx = x - half; xx <= x + half; ++xx)
        if (xx >= 0 && yy >= 0 && xx < w && yy < h && score(xx, yy) > score(x, y)) beaten = true;
    if (beaten) out[i] = Keypoint{};
  }
  return out;
}

TEST(Pfa, MatchesNaiveDenseMapAndIgnoresThreadCount) {
  std::mt19937 rng(9);
  CpuBackend one(1), two(2), five(5);
  for (int round = 0; round < 6; ++round) {
    const int w0 = 90 + round * 7, h0 = 60 + round * 3;
    const auto sizes = pyramid_level_sizes(w0, h0, 5, 1.2);
    PfaParams params{build_level_scales_q16(5, 1.2), w0, h0, round % 2 ? 5 : 3};
    // Dense random keypoints; responses from a small set in half the rounds, so scores tie.
    std::vector<Keypoint> in(600);
    for (auto& k : in) {
      if (rng() % 3 == 0) continue;
      const int n = static_cast<int>(rng() % 5);
      const int r = round % 2 ? static_cast<int>(1 + rng() % 4080) : static_cast<int>(50 * (1 + rng() % 3));
      k = kp(static_cast<int>(rng() % static_cast<unsigned>(sizes[n].first)),
             static_cast<int>(rng() % static_cast<unsigned>(sizes[n].second)), r, n);
    }
    const auto want = naive_pfa(in, params);
    int survivors = 0, rejected = 0;
    for (std::size_t i = 0; i < in.size(); ++i) {
      survivors += want[i].response != 0;
      rejected += in[i].response != 0 && want[i].response == 0;
    }
    EXPECT_GT(survivors, 0);
    EXPECT_GT(rejected, 0);
    for (CpuBackend* backend : {&one, &two, &five}) {
      const auto got = run_pfa(*backend, in, params);
      for (std::size_t i = 0; i < in.size(); ++i)
        ASSERT_EQ(str(got[i]), str(want[i]))
            << "round " << round << " cell " << i << " threads " << backend->pool().size();
    }
  }
}

// ---- Compaction --------------------------------------------------------------------------------

TEST(Compaction, CopiesNonEmptyCellsInCellOrderAndWritesTheirCount) {
  CpuBackend backend(2);
  const std::vector<Keypoint> cells{Keypoint{},     kp(3, 4, 10, 0), Keypoint{},
                                    kp(1, 2, 7, 2), kp(9, 9, 1, 1),  Keypoint{}};
  auto cells_buffer = upload_vector(backend, cells);
  auto items = backend.allocate(cells.size() * sizeof(Keypoint));
  backend.fill(*items, 0, items->size_bytes(), 0xFF);
  auto count = backend.allocate(16);  // the count lives at byte 8 of a shared counter buffer
  const DeviceList list{items.get(), count.get(), 8, static_cast<int>(cells.size())};
  backend.compact_keypoints(*cells_buffer, static_cast<int>(cells.size()), list);

  std::array<std::uint32_t, 4> counters{};
  backend.download(*count, 0, counters.data(), 16);
  EXPECT_EQ(counters, (std::array<std::uint32_t, 4>{0, 0, 3, 0}));
  EXPECT_EQ(cpu::list_count(list), 3);
  std::vector<Keypoint> out(3);
  backend.download(*items, 0, out.data(), 3 * sizeof(Keypoint));
  EXPECT_EQ(str(out[0]), str(cells[1]));
  EXPECT_EQ(str(out[1]), str(cells[3]));
  EXPECT_EQ(str(out[2]), str(cells[4]));
}

TEST(Compaction, NoKeypointsGivesCountZero) {
  CpuBackend backend(2);
  auto cells_buffer = upload_vector(backend, std::vector<Keypoint>(5));
  auto items = backend.allocate(5 * sizeof(Keypoint));
  auto count = backend.allocate(4);
  backend.fill(*count, 0, 4, 0xFF);  // a stale count from a previous frame
  backend.compact_keypoints(*cells_buffer, 5, DeviceList{items.get(), count.get(), 0, 5});
  std::uint32_t n = 1;
  backend.download(*count, 0, &n, 4);
  EXPECT_EQ(n, 0u);
}

}  // namespace
}  // namespace porta
