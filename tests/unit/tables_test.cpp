#include <gtest/gtest.h>

#include <numeric>

#include "porta/kernel_checks.hpp"
#include "porta/layout.hpp"
#include "porta/tables.hpp"

namespace porta {
namespace {

int accepted(const std::vector<std::uint8_t>& lut) { return std::accumulate(lut.begin(), lut.end(), 0); }

// A circular run of exactly k ones (9 <= k <= 14) starting at one of 16 positions has a zero on
// each side and 14 - k free bits, which cannot hold a longer run: 16 * 2^(14-k) masks. Runs of
// 15 (16 masks) and 16 (one mask) complete the count.
TEST(FastLut, BoundedRectification9To13Accepts992Masks) {
  EXPECT_EQ(accepted(build_fast_lut(9, 13)), 16 * (32 + 16 + 8 + 4 + 2));
}

TEST(FastLut, ClassicFast9To16Accepts1025Masks) {
  EXPECT_EQ(accepted(build_fast_lut(9, 16)), 16 * (32 + 16 + 8 + 4 + 2 + 1) + 16 + 1);
}

TEST(FastLut, LongestRunWrapsAroundTheCircle) {
  EXPECT_EQ(longest_circular_run(0x0000), 0);
  EXPECT_EQ(longest_circular_run(0xFFFF), 16);
  EXPECT_EQ(longest_circular_run(0x8001), 2);   // bits 15 and 0 are neighbours
  EXPECT_EQ(longest_circular_run(0xF00F), 8);
  EXPECT_EQ(longest_circular_run(0x7FFF), 15);
}

TEST(Pyramid, LevelSizesAreRoundedAndNeverZero) {
  const auto s = pyramid_level_sizes(1242, 375, 8, 1.2);
  ASSERT_EQ(s.size(), 8u);
  EXPECT_EQ(s[0], std::make_pair(1242, 375));
  EXPECT_EQ(s[1], std::make_pair(1035, 313));  // 1242/1.2 = 1035, 375/1.2 = 312.5 -> 313
  const auto tiny = pyramid_level_sizes(1, 1, 12, 1.2);
  for (const auto& [w, h] : tiny) {
    EXPECT_EQ(w, 1);
    EXPECT_EQ(h, 1);
  }
}

TEST(Pyramid, ResizeWeightsSumTo2048AndStayInside) {
  const auto sizes = pyramid_level_sizes(640, 480, 4, 1.2);
  const auto t = build_resize_tables(sizes);
  ASSERT_EQ(t.cols.size(), 3u);
  for (std::size_t n = 1; n < sizes.size(); ++n) {
    for (std::size_t j = 0; j < t.cols[n - 1].src0.size(); ++j) {
      EXPECT_GE(t.cols[n - 1].src0[j], 0);
      EXPECT_LT(t.cols[n - 1].src0[j], sizes[n - 1].first);
      EXPECT_GE(t.cols[n - 1].w1[j], 0);
      EXPECT_LE(t.cols[n - 1].w1[j], 2048);
    }
  }
  // 640 -> 533: destination column 0 samples source x = 0.5 * 640/533 - 0.5 = 0.1004 -> w1 = 206.
  EXPECT_EQ(t.cols[0].src0[0], 0);
  EXPECT_EQ(t.cols[0].w1[0], 206);
}

// Fused pyramid kernels: a 32 x 8 tile of level 2 of 64x16 -> 32x8 -> 16x4 (scale 2) reads, by
// the resize tables (source = floor((j + 0.5) * 2 - 0.5) = 2j, plus one), columns 0..31 and rows
// 0..7 of level 1: 256 bytes. With 256 bytes both levels fuse, with 255 only level 1 (which reads
// level 0 alone, whatever the capacity).
TEST(Pyramid, FusedLevelsAreThoseWhoseRegionsFitHandWorked) {
  const PyramidLayout layout = PyramidLayout::make({{64, 16}, {32, 8}, {16, 4}}, 1);
  EXPECT_EQ(checks::fused_pyramid_levels(layout, 32, 8, 256), 2);
  EXPECT_EQ(checks::fused_pyramid_levels(layout, 32, 8, 255), 1);
  EXPECT_EQ(checks::fused_pyramid_levels(layout, 32, 8, 0), 1);
  // A 31-wide level 1 pads its region rows to 32 bytes: 8 x 32 still fits 256, not 255.
  const PyramidLayout odd = PyramidLayout::make({{62, 16}, {31, 8}, {16, 4}}, 1);
  EXPECT_EQ(checks::fused_pyramid_levels(odd, 32, 8, 256), 2);
  EXPECT_EQ(checks::fused_pyramid_levels(odd, 32, 8, 255), 1);
  // Nothing to fuse: one level, or an empty level 1.
  EXPECT_EQ(checks::fused_pyramid_levels(PyramidLayout::make({{64, 16}}, 1), 32, 8, 1 << 20), 0);
  PyramidLayout empty = layout;
  empty.levels[1].width = 0;
  EXPECT_EQ(checks::fused_pyramid_levels(empty, 32, 8, 1 << 20), 0);
}

// The default pyramid (8 levels at scale 1.2) fuses whole in the GPU shaders' 8 KiB; 12 levels at
// scale 2 do not (a tile of level 11 reads ~2^10 times its width of level 1).
TEST(Pyramid, DefaultPyramidFusesWhole) {
  const PyramidLayout kitti = PyramidLayout::make(pyramid_level_sizes(1242, 375, 8, 1.2), 1);
  EXPECT_EQ(checks::fused_pyramid_levels(kitti, 32, 8, 8192), 7);
  const PyramidLayout deep = PyramidLayout::make(pyramid_level_sizes(1242, 375, 12, 2.0), 1);
  const int fused = checks::fused_pyramid_levels(deep, 32, 8, 8192);
  EXPECT_GE(fused, 1);
  EXPECT_LT(fused, 11);
}

TEST(Culling, CellSizesShrinkWithTheLevelScale) {
  const auto sizes = pyramid_level_sizes(1242, 375, 8, 1.2);
  const auto c = build_cell_layout(sizes, 32, 32, 1.2);
  EXPECT_EQ(c.levels[0].cell_w, 32);
  EXPECT_EQ(c.levels[1].cell_w, 26);  // floor(32 / 1.2)
  EXPECT_EQ(c.levels[0].cols, 39);    // ceil(1242 / 32)
  EXPECT_EQ(c.levels[0].rows, 12);    // ceil(375 / 32)
  EXPECT_EQ(c.levels[1].first_cell, 39 * 12);
  const auto half = build_cell_layout(pyramid_level_sizes(256, 256, 3, 2.0), 32, 32, 2.0);
  EXPECT_EQ(half.levels[2].cell_w, 8);  // exact quotients do not floor one below
}

TEST(Culling, FusedWorkgroupsGiveSmallGridsAQuarterOfACellsPixelsAndLargeOnes64) {
  // 256x256 halved per level with 32-pixel cells: every level has 8x8 cells, of 1024, 256 and 64
  // pixels.
  const auto half = build_cell_layout(pyramid_level_sizes(256, 256, 3, 2.0), 32, 32, 2.0);
  const checks::CellGroups g = checks::plan_cell_groups("test", "fast_cull", half, 256);
  ASSERT_EQ(g.shift.size(), 3u);
  EXPECT_EQ(g.shift[0], 8);  // 1024 px: 256 invocations, one cell per workgroup
  EXPECT_EQ(g.shift[1], 6);  // 256 px: 64 invocations, 4 cells per workgroup
  EXPECT_EQ(g.shift[2], 4);  // 64 px: 16 invocations, 16 cells per workgroup
  EXPECT_EQ(g.first_group[0], 0);
  EXPECT_EQ(g.first_group[1], 64);
  EXPECT_EQ(g.first_group[2], 64 + 16);
  EXPECT_EQ(g.groups, 64 + 16 + 4);
  // 39x12 = 468 cells of 22x22 (484 px: 128 invocations, 2 cells per workgroup) take 234
  // workgroups; of 5x5 (25 px: 8 invocations, 32 cells per workgroup) ceil(468 / 32) = 15; three
  // 1x1 cells one invocation each, in one workgroup.
  CellLayout odd;
  odd.levels.push_back({22, 22, 39, 12, 0});
  odd.levels.push_back({5, 5, 39, 12, 468});
  odd.levels.push_back({1, 1, 3, 1, 936});
  odd.levels.push_back({1, 1, 0, 0, 939});  // empty: no workgroups
  odd.total_cells = 939;
  const checks::CellGroups o = checks::plan_cell_groups("test", "fast_cull", odd, 256);
  EXPECT_EQ(o.shift[0], 7);
  EXPECT_EQ(o.shift[1], 3);
  EXPECT_EQ(o.shift[2], 0);
  EXPECT_EQ(o.first_group[1], 234);
  EXPECT_EQ(o.first_group[2], 234 + 15);
  EXPECT_EQ(o.first_group[3], 234 + 15 + 1);
  EXPECT_EQ(o.groups, 234 + 15 + 1);
  // A smaller workgroup caps the invocations per cell.
  EXPECT_EQ(checks::plan_cell_groups("test", "fast_cull", half, 64).shift[0], 6);
  // A grid of 2^18 pixels or more: 64 invocations for every level's cells, 4 to a workgroup.
  const auto kitti = build_cell_layout(pyramid_level_sizes(1242, 375, 8, 1.2), 32, 32, 1.2);
  const checks::CellGroups k = checks::plan_cell_groups("test", "fast_cull", kitti, 256);
  EXPECT_EQ(k.shift[0], 6);
  EXPECT_EQ(k.shift[7], 6);
  EXPECT_EQ(k.first_group[1], (kitti.levels[0].count() + 3) / 4);
  EXPECT_EQ(checks::plan_cell_groups("test", "fast_cull", kitti, 32).shift[0], 5);
  CellLayout edge;  // exactly 2^18 pixels: the large split
  edge.levels.push_back({32, 32, 16, 16, 0});
  edge.total_cells = 256;
  EXPECT_EQ(checks::plan_cell_groups("test", "fast_cull", edge, 256).shift[0], 6);
  edge.levels[0].rows = 15;  // 240 cells: below
  EXPECT_EQ(checks::plan_cell_groups("test", "fast_cull", edge, 256).shift[0], 8);
  // Pixels per invocation named: that many for any grid's cells. KITTI's 32 x 32 cells of level 0
  // (1024 px) at 4: 256 invocations; level 7's 8 x 8 (64 px): 16; at 16, 64 and 4; at 1, the
  // workgroup's 256 caps level 0.
  ASSERT_EQ(kitti.levels[7].cell_w, 8);
  const checks::CellGroups k4 = checks::plan_cell_groups("test", "fast_cull", kitti, 256, 4);
  EXPECT_EQ(k4.shift[0], 8);
  EXPECT_EQ(k4.shift[7], 4);
  EXPECT_EQ(k4.first_group[1], kitti.levels[0].count());
  const checks::CellGroups k16 = checks::plan_cell_groups("test", "fast_cull", kitti, 256, 16);
  EXPECT_EQ(k16.shift[0], 6);
  EXPECT_EQ(k16.shift[7], 2);
  EXPECT_EQ(checks::plan_cell_groups("test", "fast_cull", kitti, 256, 1).shift[0], 8);
  EXPECT_EQ(checks::plan_cell_groups("test", "fast_cull", kitti, 256, 1).shift[7], 6);
  // A small grid named 16: the count named, not the small grids' 4.
  EXPECT_EQ(checks::plan_cell_groups("test", "fast_cull", edge, 256, 16).shift[0], 6);
}

TEST(Blur, TapsAreSymmetricAndSumTo256) {
  const auto t = build_blur_taps();
  EXPECT_EQ(std::accumulate(t.begin(), t.end(), 0), 256);
  EXPECT_EQ(t[0], t[6]);
  EXPECT_EQ(t[1], t[5]);
  EXPECT_EQ(t[2], t[4]);
  EXPECT_GT(t[3], t[2]);
  EXPECT_EQ(reflect101(-1, 10), 1);
  EXPECT_EQ(reflect101(10, 10), 8);
  EXPECT_EQ(reflect101(-3, 2), 1);
  EXPECT_EQ(reflect101(5, 1), 0);
}

TEST(Orb, RotatedPatternStaysWithin18Pixels) {
  const auto table = build_orb_pattern_table(32);
  ASSERT_EQ(table.size(), 32u * 256 * 4);
  for (auto v : table) {
    EXPECT_GE(v, -18);
    EXPECT_LE(v, 18);
  }
  // Bin 0 is the unrotated pattern.
  const auto& base = orb_base_pattern();
  for (int i = 0; i < 256; ++i)
    for (int c = 0; c < 4; ++c) EXPECT_EQ(table[static_cast<std::size_t>(i) * 4 + c], base[i][c]);
}

TEST(Orb, PatternOfBinPlusQuarterIsTheQuarterTurnForEveryBinCount) {
  for (int bins = 4; bins <= 64; bins += 4) {
    const auto t = build_orb_pattern_table(bins);
    for (int b = 0; b < bins; ++b) {
      const int b90 = (b + bins / 4) % bins;
      for (int i = 0; i < 256 * 2; ++i) {  // every point: (x, y) turned is (-y, x)
        const auto x = t[(static_cast<std::size_t>(b) * 512 + i) * 2];
        const auto y = t[(static_cast<std::size_t>(b) * 512 + i) * 2 + 1];
        ASSERT_EQ(t[(static_cast<std::size_t>(b90) * 512 + i) * 2], -y) << "bins " << bins << " bin " << b;
        ASSERT_EQ(t[(static_cast<std::size_t>(b90) * 512 + i) * 2 + 1], x) << "bins " << bins << " bin " << b;
      }
    }
  }
}

TEST(Orientation, UmaxIsTheDiscOfSquaredRadius240) {
  const auto u = build_orientation_umax();
  EXPECT_EQ(u[0], 15);
  EXPECT_EQ(u[15], 3);  // 3^2 + 15^2 = 234 <= 240 < 4^2 + 15^2
}

TEST(Settings, RejectsOutOfRangeFieldsByName) {
  FrontendSettings s;
  EXPECT_NO_THROW(s.validate());
  s.levels = 13;
  try {
    s.validate();
    FAIL() << "levels = 13 accepted";
  } catch (const SettingsError& e) {
    EXPECT_NE(std::string(e.what()).find("levels"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("[1, 12]"), std::string::npos);
  }
  s = {};
  s.max_arc = 8;  // below min_arc
  EXPECT_THROW(s.validate(), SettingsError);
  s = {};
  s.scale_factor = 1.0;
  EXPECT_THROW(s.validate(), SettingsError);
  s = {};
  s.pfa_window = 4;
  EXPECT_THROW(s.validate(), SettingsError);
  s = {};
  s.edge = 5;
  EXPECT_THROW(s.validate(), SettingsError);
}

TEST(Tables, RejectsImagesLargerThanTheFixedPointRange) {
  EXPECT_THROW(FrontendTables::build(FrontendSettings{}, 20000, 10), std::invalid_argument);
  EXPECT_THROW(FrontendTables::build(FrontendSettings{}, 0, 10), std::invalid_argument);
}

}  // namespace
}  // namespace porta
