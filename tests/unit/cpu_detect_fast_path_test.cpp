// The cpu backend's vectorised fast_crf and cull_cells (32 / 16 lanes with overlapping last
// blocks, and scalar paths for narrow rows and negative thresholds) against plain re-implementations
// of DESIGN.md §3.3 and §3.4 written here: odd widths, every threshold regime, unusual tables,
// high-contrast and flat images, cells from 1 x 1 to larger than the level.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <climits>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "detect_runners.hpp"
#include "porta/tables.hpp"
#include "support/test_images.hpp"

namespace porta {
namespace {

using cpu::CpuBackend;
using test::ResponsePlanes;

// ---- Contract re-implementations ---------------------------------------------------------------

// §3.3 for one pixel: the radius-3 Bresenham circle clockwise from 12 o'clock, bit i of `bright`
// when I_i > c + eps, of `dark` when I_i < c - eps (in 64-bit, so any int eps is meant literally),
// a corner when the table accepts either mask; response sum |I_i - c| or 0.
std::uint16_t contract_fast(const Image& img, int x, int y, int eps, int edge,
                            const std::vector<std::uint8_t>& lut) {
  if (x < edge || y < edge || x >= img.width() - edge || y >= img.height() - edge) return 0;
  static constexpr int kDx[16] = {0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3, -3, -3, -2, -1};
  static constexpr int kDy[16] = {-3, -3, -2, -1, 0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3};
  const std::int64_t c = img.at(x, y);
  unsigned bright = 0, dark = 0, sum = 0;
  for (int i = 0; i < 16; ++i) {
    const std::int64_t p = img.at(x + kDx[i], y + kDy[i]);
    if (p > c + eps) bright |= 1u << i;
    if (p < c - eps) dark |= 1u << i;
    sum += static_cast<unsigned>(p > c ? p - c : c - p);
  }
  return (lut[bright] != 0 || lut[dark] != 0) ? static_cast<std::uint16_t>(sum) : 0;
}

// §3.4 for every cell of every level: the largest response, ties to the smaller row, then the
// smaller column, as an explicit comparison; an all-zero record when the maximum is 0.
std::vector<Keypoint> contract_cull(const std::vector<std::pair<int, int>>& sizes,
                                    const ResponsePlanes& planes, const CellLayout& cells) {
  std::vector<Keypoint> out(static_cast<std::size_t>(cells.total_cells));
  for (std::size_t n = 0; n < sizes.size(); ++n) {
    const auto [w, h] = sizes[n];
    const LevelCells& g = cells.levels[n];
    for (int row = 0; row < g.rows; ++row)
      for (int col = 0; col < g.cols; ++col) {
        Keypoint best{};
        for (int y = row * g.cell_h; y < std::min((row + 1) * g.cell_h, h); ++y)
          for (int x = col * g.cell_w; x < std::min((col + 1) * g.cell_w, w); ++x) {
            const std::uint16_t r = planes[n][static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + x];
            const bool better = r > best.response ||
                                (r == best.response && r > 0 && (y < best.y || (y == best.y && x < best.x)));
            if (better) {
              best.x = static_cast<std::uint16_t>(x);
              best.y = static_cast<std::uint16_t>(y);
              best.response = r;
              best.level = static_cast<std::uint8_t>(n);
            }
          }
        out[static_cast<std::size_t>(g.first_cell + row * g.cols + col)] = best;
      }
  }
  return out;
}

std::string str(const Keypoint& k) {
  return "{x " + std::to_string(k.x) + ", y " + std::to_string(k.y) + ", r " + std::to_string(k.response) +
         ", level " + std::to_string(k.level) + ", bin " + std::to_string(k.angle_bin) + "}";
}

// ---- Inputs ------------------------------------------------------------------------------------

/// Pixels drawn uniformly from `values` (e.g. {0, 255}: every circle pixel far from the centre).
Image image_of_values(int width, int height, const std::vector<std::uint8_t>& values, std::uint32_t seed,
                      int pitch_bytes = 0) {
  Image img(width, height, pitch_bytes);
  std::mt19937 rng(seed);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) img.at(x, y) = values[rng() % values.size()];
  return img;
}

/// 65 536 entries: 1 for every mask `accept` says yes to.
template <typename Accept>
std::vector<std::uint8_t> table_of(Accept accept) {
  std::vector<std::uint8_t> lut(65536);
  for (unsigned m = 0; m < 65536; ++m) lut[m] = accept(m) ? 1 : 0;
  return lut;
}

struct NamedTable {
  std::string name;
  std::vector<std::uint8_t> lut;
};

std::vector<NamedTable> tables() {
  return {
      {"arc 9..13", build_fast_lut(9, 13)},
      {"arc 9..16", build_fast_lut(9, 16)},
      {"arc 12..12", build_fast_lut(12, 12)},
      // The vector step tests an arc table's runs itself (run lengths 1 to 16 and their ends).
      {"arc 1..16", build_fast_lut(1, 16)},
      {"arc 1..1", build_fast_lut(1, 1)},
      {"arc 16..16", build_fast_lut(16, 16)},
      {"arc 3..8", build_fast_lut(3, 8)},
      // An arc table less one of its masks, and one more: no longer an arc table (looked up).
      {"arc 9..13 less one", [] {
         auto lut = build_fast_lut(9, 13);
         lut[0x01FF] = 0;
         return lut;
       }()},
      {"arc 9..13 and one", [] {
         auto lut = build_fast_lut(9, 13);
         lut[0x00FF] = 1;
         return lut;
       }()},
      // Not arc tables: exactly 9 bits set anywhere (a pixel with exactly the fewest bits must be
      // looked at), a single bit, the empty mask (every pixel looked at), and nothing at all.
      {"popcount 9", table_of([](unsigned m) { return std::popcount(m) == 9; })},
      {"popcount 1", table_of([](unsigned m) { return std::popcount(m) == 1; })},
      {"empty mask", table_of([](unsigned m) { return m == 0; })},
      // Every accepted mask has bit 0 or 8 and bit 3 or 11, no other opposite pair: the vector
      // step's pairs test then rejects on those two pairs only.
      {"pairs 0 and 3", table_of([](unsigned m) { return (m & 0x0101u) && (m & 0x0808u) && std::popcount(m) >= 4; })},
      {"none", std::vector<std::uint8_t>(65536, 0)},
  };
}

// ---- FAST CRF ----------------------------------------------------------------------------------

void expect_fast_matches_contract(CpuBackend& backend, const std::vector<Image>& levels,
                                  const NamedTable& table, FastParams params, int level0_pitch,
                                  int& corners) {
  const ResponsePlanes got = test::run_fast_crf(backend, levels, table.lut, params, level0_pitch);
  for (std::size_t n = 0; n < levels.size(); ++n) {
    const Image& img = levels[n];
    for (int y = 0; y < img.height(); ++y)
      for (int x = 0; x < img.width(); ++x) {
        const std::uint16_t want = contract_fast(img, x, y, params.threshold, params.edge, table.lut);
        ASSERT_EQ(got[n][static_cast<std::size_t>(y) * static_cast<std::size_t>(img.width()) + x], want)
            << img.width() << "x" << img.height() << " level " << n << " at " << x << "," << y << ", table "
            << table.name << ", eps " << params.threshold << ", edge " << params.edge;
        corners += want != 0;
      }
  }
}

// Widths around the 32-pixel blocks: interiors (width - 2 * edge) of 0, 1, 31, 32, 33, 63, 64, 65
// and a KITTI row; high-contrast pixels (near 0 and 255, so the saturated thresholds matter),
// uniform random ones and a textured pyramid; every threshold regime, including eps outside
// [0, 255] (negative: bright and dark overlap; >= 255: nothing passes) and the int extremes.
TEST(CpuDetectFastPath, FastCrfMatchesContractOnOddWidthsThresholdsAndTables) {
  CpuBackend backend(2);
  const std::vector<std::uint8_t> extremes{0, 1, 2, 127, 128, 253, 254, 255};
  struct Case {
    std::vector<Image> levels;
    int edge;
    int level0_pitch;
  };
  std::vector<Case> cases;
  std::uint32_t seed = 1;
  for (const int interior : {0, 1, 31, 32, 33, 63, 64, 65}) {
    cases.push_back({{image_of_values(interior + 6, 9, extremes, seed++)}, 3, 0});
    cases.push_back({{test::random_image(interior + 6, 8, seed++)}, 3, interior + 6});  // tight pitch
  }
  cases.push_back({{image_of_values(1242, 7, extremes, seed++)}, 3, 0});
  cases.push_back({{test::random_image(77, 45, seed++)}, 19, 0});
  cases.push_back({{test::random_image(7, 7, seed++)}, 3, 0});   // one row and column of interior
  cases.push_back({{test::random_image(6, 40, seed++)}, 3, 0});  // no interior column
  cases.push_back({{test::flat_image(70, 9, 0)}, 3, 0});
  cases.push_back({{test::flat_image(70, 9, 255)}, 3, 0});
  cases.push_back({{test::checkerboard(71, 12, 2)}, 3, 0});
  std::vector<Image> pyramid;
  for (const auto& [w, h] : pyramid_level_sizes(97, 60, 6, 1.3))
    pyramid.push_back(test::textured_image(w, h, seed++));
  cases.push_back({std::move(pyramid), 3, 0});

  int corners = 0;
  for (const NamedTable& table : tables())
    for (const int eps : {0, 1, 20, 254, 255, 256, 1000, INT_MAX, -1, -20, -255, -256, -1000, INT_MIN})
      for (const Case& c : cases)
        ASSERT_NO_FATAL_FAILURE(expect_fast_matches_contract(
            backend, c.levels, table, FastParams{eps, c.edge}, c.level0_pitch, corners));
  EXPECT_GT(corners, 10000);  // the comparison covered real corners, not only zeros
}

// One bright dot on black at each interior column in turn: its response is 16 * 255 (a full
// circle of dark pixels, classic FAST), and nothing else responds. Every lane of every block,
// the overlapping last block and the scalar narrow rows each see a corner once.
TEST(CpuDetectFastPath, LoneCornerIsFoundAtEveryColumn) {
  CpuBackend backend(2);
  const std::vector<std::uint8_t> lut = build_fast_lut(9, 16);
  for (const int width : {7, 37, 38, 39, 69, 70, 71, 103}) {
    for (int x = 3; x < width - 3; ++x) {
      Image img = test::flat_image(width, 7, 0);
      img.at(x, 3) = 255;
      const ResponsePlanes got = test::run_fast_crf(backend, {std::move(img)}, lut, FastParams{20, 3});
      for (int i = 0; i < width * 7; ++i) {
        const int want = i == 3 * width + x ? 16 * 255 : 0;
        ASSERT_EQ(got[0][static_cast<std::size_t>(i)], want)
            << "width " << width << ", dot at x " << x << ": wrong response at " << i % width << ","
            << i / width;
      }
    }
  }
}

// ---- Culling -----------------------------------------------------------------------------------

/// Cells of cell_w x cell_h over each level, with `extra_cols` (may be negative) more columns and
/// `extra_rows` more rows than the level needs.
CellLayout tiled_cells(const std::vector<std::pair<int, int>>& sizes, int cell_w, int cell_h,
                       int extra_cols = 0, int extra_rows = 0) {
  CellLayout layout;
  for (const auto& [w, h] : sizes) {
    LevelCells g;
    g.cell_w = cell_w;
    g.cell_h = cell_h;
    g.cols = std::max(0, (w + cell_w - 1) / cell_w + extra_cols);
    g.rows = std::max(0, (h + cell_h - 1) / cell_h + extra_rows);
    g.first_cell = layout.total_cells;
    layout.total_cells += g.count();
    layout.levels.push_back(g);
  }
  return layout;
}

/// Per level: sparse few distinct values (ties and empty cells), the full uint16 range (values
/// above 0x7FFF order as unsigned), or one constant (every pixel ties).
ResponsePlanes response_planes(const std::vector<std::pair<int, int>>& sizes, int kind, std::uint32_t seed) {
  std::mt19937 rng(seed);
  ResponsePlanes planes;
  for (const auto& [w, h] : sizes) {
    std::vector<std::uint16_t> plane(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
    for (auto& r : plane) {
      if (kind == 0) r = (rng() % 5 == 0) ? static_cast<std::uint16_t>(1 + rng() % 3) : 0;
      if (kind == 1) r = static_cast<std::uint16_t>(rng() % 3 == 0 ? 65535 - rng() % 4 : rng());
      if (kind == 2) r = 7;
    }
    planes.push_back(std::move(plane));
  }
  return planes;
}

void expect_cull_matches_contract(CpuBackend& backend, const std::vector<std::pair<int, int>>& sizes,
                                  const CellLayout& cells, int kind, int level0_pitch,
                                  const std::string& what) {
  const ResponsePlanes planes =
      response_planes(sizes, kind, static_cast<std::uint32_t>(cells.total_cells + kind));
  const std::vector<Keypoint> got = test::run_cull_cells(backend, sizes, planes, cells, level0_pitch);
  const std::vector<Keypoint> want = contract_cull(sizes, planes, cells);
  for (int i = 0; i < cells.total_cells; ++i)
    ASSERT_EQ(str(got[static_cast<std::size_t>(i)]), str(want[static_cast<std::size_t>(i)]))
        << "cell " << i << ", " << what << ", values kind " << kind;
}

// Levels narrower and wider than the 16-lane strips (1, 15, 16, 17, 33, 1242 columns), cells from
// 1 x 1 to larger than the level, rectangular both ways, with a tight pitch too.
TEST(CpuDetectFastPath, CullCellsMatchesContractOnManyCellShapes) {
  CpuBackend backend(2);
  const std::vector<std::pair<int, int>> level_sizes{{1, 1},   {5, 3},   {15, 9},  {16, 16},   {17, 5},
                                                     {31, 33}, {33, 17}, {65, 40}, {1242, 40}, {100, 1}};
  const std::vector<std::pair<int, int>> cell_sizes{{1, 1},  {1, 3},   {3, 1},    {2, 2},   {7, 3},
                                                    {8, 8},  {16, 16}, {16, 10},  {17, 16}, {32, 32},
                                                    {5, 40}, {64, 8},  {100, 100}};
  for (const auto& size : level_sizes)
    for (const auto& [cw, ch] : cell_sizes)
      for (int kind = 0; kind < 3; ++kind)
        for (const int pitch : {0, size.first}) {
          const std::string what = std::to_string(size.first) + "x" + std::to_string(size.second) +
                                   " level, " + std::to_string(cw) + "x" + std::to_string(ch) +
                                   " cells, pitch " + std::to_string(pitch);
          ASSERT_NO_FATAL_FAILURE(
              expect_cull_matches_contract(backend, {size}, tiled_cells({size}, cw, ch), kind, pitch, what));
        }
}

// A frame's pyramid with the table-built cells (32 px at level 0 down to 1 x 1 at the top), and
// layouts with cells past the level's border (empty records) or fewer columns than it needs.
TEST(CpuDetectFastPath, CullCellsMatchesContractOnPyramidsAndUnusualLayouts) {
  CpuBackend backend(2);
  const auto kitti = pyramid_level_sizes(1242, 375, 8, 1.2);
  for (int kind = 0; kind < 3; ++kind) {
    ASSERT_NO_FATAL_FAILURE(expect_cull_matches_contract(
        backend, kitti, build_cell_layout(kitti, 32, 32, 1.2), kind, 0, "kitti 32"));
    ASSERT_NO_FATAL_FAILURE(expect_cull_matches_contract(backend, kitti, build_cell_layout(kitti, 24, 9, 2.0),
                                                         kind, 0, "kitti 24x9"));
  }
  const std::vector<std::pair<int, int>> sizes{{70, 23}, {37, 11}, {16, 4}};
  for (const auto& [extra_cols, extra_rows] :
       std::vector<std::pair<int, int>>{{1, 0}, {0, 2}, {-1, 0}, {-2, -1}})
    for (const auto& [cw, ch] : std::vector<std::pair<int, int>>{{8, 8}, {5, 3}, {1, 1}})
      for (int kind = 0; kind < 3; ++kind)
        ASSERT_NO_FATAL_FAILURE(expect_cull_matches_contract(
            backend, sizes, tiled_cells(sizes, cw, ch, extra_cols, extra_rows), kind, 0,
            std::to_string(cw) + "x" + std::to_string(ch) + " cells, " + std::to_string(extra_cols) +
                " cols and " + std::to_string(extra_rows) + " rows extra"));
}

// Equal maxima in one cell at every pair of positions of a 2-row, 20-column cell: the smaller
// row wins, then the smaller column, whichever 16-column strip each lies in.
TEST(CpuDetectFastPath, CullTiesGoToSmallerRowThenColumnAcrossStrips) {
  CpuBackend backend(2);
  const std::vector<std::pair<int, int>> sizes{{20, 2}};
  const CellLayout cells = tiled_cells(sizes, 20, 2);
  for (int a = 0; a < 40; ++a)
    for (int b = a + 1; b < 40; ++b) {
      ResponsePlanes planes{std::vector<std::uint16_t>(40, 3)};
      planes[0][static_cast<std::size_t>(a)] = 900;
      planes[0][static_cast<std::size_t>(b)] = 900;
      const std::vector<Keypoint> got = test::run_cull_cells(backend, sizes, planes, cells);
      ASSERT_EQ(got[0].response, 900);
      ASSERT_EQ(got[0].y * 20 + got[0].x, a) << "900 at " << a << " and " << b;  // a comes first row-major
    }
}

}  // namespace
}  // namespace porta
