// Host mirrors of the structs of shaders/opencl/common.cl, passed to kernels by value.
#pragma once

#include <CL/cl.h>

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "porta/backend.hpp"
#include "porta/kernel_checks.hpp"
#include "porta/layout.hpp"

namespace porta::opencl {

inline constexpr int kMaxLevels = 12;

struct ClPlane {
  cl_int offset_bytes, width, height, pitch;
};
struct ClLevels {
  ClPlane level[kMaxLevels];
  cl_int count, pad[3];
};
struct ClLevelCells {
  cl_int cell_w, cell_h, cols, rows, first_cell;
  cl_int first_group, group_shift, pad;  // fast_cull_group's work split (checks::CellGroups), else 0
};
struct ClCells {
  ClLevelCells level[kMaxLevels];
  cl_int count, total_cells, pad[2];
};
struct ClLevelInts {
  cl_int v[kMaxLevels];
};
/// common.cl porta_tiles: the work-groups of a kernel that runs all levels in one launch, one per
/// kTileW x kTileH tile (checks::tile_levels).
inline constexpr int kTileW = 32;
inline constexpr int kTileH = 8;
struct ClTiles {
  cl_int first[kMaxLevels + 4];
  cl_int across[kMaxLevels];
};
static_assert(sizeof(ClTiles) == 16 * 4 + 12 * 4);
static_assert(sizeof(ClLevels) == 12 * 16 + 16);
static_assert(sizeof(ClCells) == 12 * 32 + 16);

inline ClPlane to_cl(const Plane& p) {
  return {static_cast<cl_int>(p.offset_bytes), p.width, p.height, p.pitch};
}

inline ClLevels to_cl(const PyramidLayout& layout) {
  if (layout.num_levels() > kMaxLevels) throw BackendError("opencl: more than 12 pyramid levels");
  ClLevels l{};
  l.count = layout.num_levels();
  for (int n = 0; n < l.count; ++n) l.level[n] = to_cl(layout.levels[static_cast<std::size_t>(n)]);
  return l;
}

inline ClCells to_cl(const CellLayout& cells) {
  if (cells.levels.size() > static_cast<std::size_t>(kMaxLevels)) throw BackendError("opencl: more than 12 cell levels");
  ClCells c{};
  c.count = static_cast<cl_int>(cells.levels.size());
  c.total_cells = cells.total_cells;
  for (std::size_t n = 0; n < cells.levels.size(); ++n) {
    const auto& l = cells.levels[n];
    c.level[n] = {l.cell_w, l.cell_h, l.cols, l.rows, l.first_cell, 0, 0, 0};
  }
  return c;
}

/// The tiles of `layout` (at most kMaxLevels levels) and their total.
inline ClTiles tiles_of(const PyramidLayout& layout, const char* kernel, std::size_t& total) {
  if (layout.num_levels() > kMaxLevels) throw BackendError("opencl: more than 12 pyramid levels");
  const checks::LevelTiles t = checks::tile_levels("opencl", kernel, layout, kTileW, kTileH);
  ClTiles c{};
  for (std::size_t n = 0; n < t.across.size(); ++n) {
    c.first[n] = t.first[n];
    c.across[n] = t.across[n];
  }
  c.first[t.across.size()] = t.first.back();
  total = static_cast<std::size_t>(t.first.back());
  return c;
}

inline ClLevelInts to_cl_ints(const std::vector<std::int32_t>& v) {
  if (v.size() > static_cast<std::size_t>(kMaxLevels)) throw BackendError("opencl: more than 12 per-level values");
  ClLevelInts out{};
  for (std::size_t i = 0; i < v.size(); ++i) out.v[i] = v[i];
  return out;
}

}  // namespace porta::opencl
