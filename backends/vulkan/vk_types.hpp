// Host mirrors of the structs of shaders/vulkan/common.glsl (std430 layout, passed as push
// constants or in the parameter buffer), and the argument checks the kernel files share (those of
// porta/kernel_checks.hpp with the Vulkan backend's name and plane limits).
// Internal to backends/vulkan.
#pragma once

#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "porta/backend.hpp"
#include "porta/kernel_checks.hpp"
#include "porta/layout.hpp"

namespace porta::vulkan {

inline constexpr int kMaxLevels = 12;

struct GlslPlane {
  std::int32_t offset_bytes, width, height, pitch;
};
struct GlslLevels {
  GlslPlane level[kMaxLevels];
  std::int32_t count, pad[3];
};
struct GlslLevelCells {
  std::int32_t cell_w, cell_h, cols, rows, first_cell;
  std::int32_t first_group, group_shift, pad;  // fast_cull.comp's work split (checks::CellGroups), else 0
};
struct GlslCells {
  GlslLevelCells level[kMaxLevels];
  std::int32_t count, total_cells, pad[2];
};
/// common.glsl Tiles: the workgroups of a kernel that runs all levels in one dispatch, one per
/// kTileW x kTileH tile (checks::tile_levels).
inline constexpr int kTileW = 32;
inline constexpr int kTileH = 8;
struct GlslTiles {
  std::int32_t first[kMaxLevels + 4];
  std::int32_t across[kMaxLevels];
};
static_assert(sizeof(GlslTiles) == 16 * 4 + 12 * 4);
static_assert(sizeof(GlslPlane) == 16);
static_assert(sizeof(GlslLevels) == 12 * 16 + 16);
static_assert(sizeof(GlslCells) == 12 * 32 + 16);

inline GlslPlane to_glsl(const Plane& p) {
  return {static_cast<std::int32_t>(p.offset_bytes), p.width, p.height, p.pitch};
}

inline GlslLevels to_glsl(const PyramidLayout& layout, const char* kernel) {
  if (layout.num_levels() > kMaxLevels)
    throw BackendError(std::string("vulkan: ") + kernel + ": " + std::to_string(layout.num_levels()) +
                       " levels; at most 12");
  GlslLevels l{};
  l.count = layout.num_levels();
  for (int n = 0; n < l.count; ++n) l.level[n] = to_glsl(layout.levels[static_cast<std::size_t>(n)]);
  return l;
}

inline GlslCells to_glsl(const CellLayout& cells, const char* kernel) {
  if (cells.levels.size() > static_cast<std::size_t>(kMaxLevels))
    throw BackendError(std::string("vulkan: ") + kernel + ": " + std::to_string(cells.levels.size()) +
                       " cell levels; at most 12");
  GlslCells c{};
  c.count = static_cast<std::int32_t>(cells.levels.size());
  c.total_cells = cells.total_cells;
  for (std::size_t n = 0; n < cells.levels.size(); ++n) {
    const auto& l = cells.levels[n];
    c.level[n] = {l.cell_w, l.cell_h, l.cols, l.rows, l.first_cell, 0, 0, 0};
  }
  return c;
}

inline constexpr const char* kBackend = "vulkan";
/// Shaders index planes of their element type with int32, so planes must also end below 2^31 bytes.
inline constexpr checks::PlaneLimits kPlaneLimits{.aligned = true,
                                                  .max_end = std::numeric_limits<std::int32_t>::max()};

inline void require_plane_inside(const Buffer& buffer, const Plane& plane, int element_bytes,
                                 const char* kernel, const char* what) {
  checks::check_plane(kBackend, kernel, what, buffer, plane, element_bytes, kPlaneLimits);
}

inline void require_bytes(const Buffer& buffer, std::int64_t bytes, const char* kernel,
                          const std::string& what) {
  checks::check_bytes(kBackend, kernel, what, buffer, bytes);
}

inline void check_same_level_sizes(const PyramidLayout& a, const PyramidLayout& b, const char* kernel) {
  checks::check_same_level_sizes(kBackend, kernel, a, b);
}

/// `layout` with empty levels given no rows, for shaders that lay the rows of all levels end to
/// end; also the widest level and the total number of rows.
inline GlslLevels rows_of_levels(const PyramidLayout& layout, const char* kernel, std::uint64_t& max_width,
                                 std::uint64_t& rows) {
  GlslLevels l = to_glsl(layout, kernel);
  max_width = 0;
  rows = 0;
  for (int n = 0; n < l.count; ++n) {
    if (l.level[n].width <= 0 || l.level[n].height <= 0) {
      l.level[n].width = 0;
      l.level[n].height = 0;
      continue;
    }
    max_width = std::max<std::uint64_t>(max_width, static_cast<std::uint64_t>(l.level[n].width));
    rows += static_cast<std::uint64_t>(l.level[n].height);
  }
  return l;
}

/// The tiles of `layout` (at most kMaxLevels levels, to_glsl checks) and their total.
inline GlslTiles tiles_of(const PyramidLayout& layout, const char* kernel, std::uint64_t& total) {
  const checks::LevelTiles t = checks::tile_levels(kBackend, kernel, layout, kTileW, kTileH);
  GlslTiles g{};
  for (std::size_t n = 0; n < t.across.size() && n < static_cast<std::size_t>(kMaxLevels); ++n) {
    g.first[n] = t.first[n];
    g.across[n] = t.across[n];
  }
  g.first[std::min<std::size_t>(t.across.size(), kMaxLevels)] = t.first.back();
  total = static_cast<std::uint64_t>(t.first.back());
  return g;
}

/// The list slots a kernel launched over a device list's capacity may touch
/// (checks::usable_capacity), after refusing a count that does not lie inside its buffer (the
/// shaders read it at a uint32 byte offset).
inline int usable_capacity(const ConstDeviceList& list,
                           std::initializer_list<std::pair<const Buffer*, std::size_t>> buffers,
                           const char* kernel) {
  checks::check_count_offset(kBackend, kernel, list, std::numeric_limits<std::int32_t>::max());
  return checks::usable_capacity(list, buffers);
}

}  // namespace porta::vulkan
