// Detection kernels of the OpenCL backend: FAST corner response, per-cell culling, pyramidal
// feature aggregation (PFA) and the canonical compaction of the cell array (DESIGN.md §3.3-3.5);
// device code in shaders/opencl/detect.cl. No host round-trips: PFA and compaction keep their
// intermediate state in device scratch memory.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "opencl/cl_types.hpp"
#include "opencl/opencl_backend.hpp"
#include "porta/kernel_checks.hpp"

namespace porta::opencl {

namespace {

constexpr const char* kBackend = "opencl";
// Kernels index planes of their element type with cl_int offsets.
constexpr checks::PlaneLimits kPlanes{true, std::numeric_limits<cl_int>::max()};

// Every level of `layout` with empty levels given no rows; the widest level and the total rows.
ClLevels rows_of_levels(const PyramidLayout& layout, std::size_t& max_width, std::size_t& rows) {
  ClLevels l = to_cl(layout);
  max_width = 0;
  rows = 0;
  for (int n = 0; n < l.count; ++n) {
    if (l.level[n].width <= 0 || l.level[n].height <= 0) {
      l.level[n].width = 0;
      l.level[n].height = 0;
      continue;
    }
    max_width = std::max(max_width, static_cast<std::size_t>(l.level[n].width));
    rows += static_cast<std::size_t>(l.level[n].height);
  }
  return l;
}

constexpr int kCompactBlock = 128;  // cells per work-item of the compaction
/// PFA runs in one work-group (pfa_group) up to this many cells, in three launches above (as on
/// vulkan: one group is faster for a few hundred cells, slower for ~1 500).
constexpr int kPfaGroupCells = 512;

/// detect.cl's porta_pfa is checks::PfaSetup byte for byte: 12 scales, then total_cells,
/// num_scales, width0, height0 and reach, all 32-bit (passed to the kernels as it is).
using ClPfa = checks::PfaSetup;
static_assert(sizeof(ClPfa) == 48 + 5 * 4 && std::is_trivially_copyable_v<ClPfa>);

/// fast_crf's checks of its arguments.
void check_fast(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut, const Buffer& responses,
                const PyramidLayout& response_layout, const FastParams& params) {
  checks::check_fast(kBackend, pyramid, layout, lut, responses, response_layout, params, kPlanes);
}

/// cull_cells' checks of its arguments; returns the end of the last cell grid (the cells it writes).
std::int64_t check_cull(const Buffer& responses, const PyramidLayout& response_layout, const CellLayout& cell_layout,
                        const Buffer& cells) {
  return checks::check_cull(kBackend, responses, response_layout, cell_layout, cells, 0, kPlanes);
}

/// pfa_filter's checks of its arguments; returns the kernels' parameters (total_cells 0: nothing
/// to do). The maps are indexed with 32-bit offsets of 4-byte entries.
ClPfa check_pfa(const Buffer& cells, const CellLayout& cell_layout, const PfaParams& params) {
  return checks::check_pfa(kBackend, cells, cell_layout, params, std::numeric_limits<std::uint32_t>::max() / 4);
}

/// pfa_compact_group runs PFA's steps A and B up to this many cells, as vulkan's: each step one
/// round of the work-group. Over the ~1 500 cells of an 8-level 1242x375 image it takes two, and on
/// the H200 that cost the device more than the host saved on launches: 234 against 207 us per
/// stereo pair with the separate PFA and compaction, 4 frames in flight and pinned input, where the
/// device bounds opencl. Above, fast_cull_group does step A and pfa_decide step B, and
/// pfa_compact_group step C and the compaction, whatever the count.
constexpr int kPfaCompactGroupCells = 512;
/// pfa_compact_group's pfa_steps: which of PFA's steps it runs.
constexpr cl_int kPfaAccumulate = 1, kPfaDecide = 2, kPfaApply = 4;
/// fast_cull_group's work-group size (its reqd_work_group_size).
constexpr int kFastCullGroup = 256;

}  // namespace

// §3.3, one launch. GPUs: one work-group per 32 x 8 tile of any level, the tile read once into
// local memory (fast_tiled); elsewhere one work-item per row of every level (fast_crf).
void OpenClBackend::fast_crf(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                             Buffer& responses, const PyramidLayout& response_layout, const FastParams& params) {
  check_fast(pyramid, layout, lut, responses, response_layout, params);
  if (work_groups()) {
    std::size_t tiles = 0;
    const ClTiles t = tiles_of(layout, "fast_crf", tiles);
    if (tiles == 0) return;
    launch("detect", "fast_tiled", Range::tiles(tiles), pyramid, to_cl(layout), lut, responses,
           to_cl(response_layout), t, static_cast<cl_int>(params.threshold), static_cast<cl_int>(params.edge));
    return;
  }
  std::size_t max_width = 0, rows = 0;
  const ClLevels src = rows_of_levels(layout, max_width, rows);
  if (rows == 0) return;
  launch("detect", "fast_crf", Range::linear(rows), pyramid, src, lut, responses, to_cl(response_layout),
         static_cast<cl_int>(params.threshold), static_cast<cl_int>(params.edge));
}

/// Cells of at most this many pixels are culled one work-item per cell: a 64-wide work-group and
/// its barriers for a handful of pixels cost more than the scan (as on vulkan).
constexpr std::int64_t kSmallCellPixels = 256;

// §3.4: one launch over the cells of every level: a work-group per large cell, else a work-item.
void OpenClBackend::cull_cells(const Buffer& responses, const PyramidLayout& response_layout,
                               const CellLayout& cell_layout, Buffer& cells) {
  const std::int64_t end_cell = check_cull(responses, response_layout, cell_layout, cells);
  if (end_cell == 0) return;
  // Large cells on a GPU: a 64-wide work-group per cell (cull_cells_group); small ones, a CPU
  // device (work_groups()), or a grid the group kernel's 32-bit cell index cannot hold: one
  // work-item per cell. The same bytes either way.
  std::int64_t largest_cell = 0;
  bool regular = true;
  for (const LevelCells& c : cell_layout.levels) {
    regular = regular && c.cell_w > 0 && c.cell_h > 0;
    largest_cell = std::max(largest_cell, static_cast<std::int64_t>(c.cell_w) * c.cell_h);
  }
  if (work_groups() && regular && largest_cell > kSmallCellPixels && largest_cell <= (std::int64_t{1} << 24)) {
    launch("detect", "cull_cells_group", Range::linear(static_cast<std::size_t>(end_cell) * 64, 64), responses,
           to_cl(response_layout), to_cl(cell_layout), cells);
    return;
  }
  launch("detect", "cull_cells", Range::linear(static_cast<std::size_t>(end_cell)), responses,
         to_cl(response_layout), to_cl(cell_layout), cells);
}

// §3.5: three steps over the cells (accumulate, decide, apply) with two level-0 sized scratch maps
// that are zero between calls (zero when allocated, restored by the last step). GPUs, a few
// hundred cells: the three in one work-group (pfa_group); otherwise three launches.
void OpenClBackend::pfa_filter(Buffer& cells, const CellLayout& cell_layout, const PfaParams& params) {
  const ClPfa p = check_pfa(cells, cell_layout, params);
  const int total = p.total_cells;
  if (total <= 0) return;
  const std::int64_t pixels0 = static_cast<std::int64_t>(p.width0) * p.height0;
  Buffer& sum_map = scratch("pfa_sum", static_cast<std::size_t>(pixels0) * 4);
  Buffer& level_map = scratch("pfa_levels", static_cast<std::size_t>(pixels0) * 4);
  Buffer& rejected = scratch("pfa_rejected", static_cast<std::size_t>(total));
  if (work_groups() && total <= kPfaGroupCells && max_work_group() >= 1024) {
    launch("detect", "pfa_group", Range::linear(1024, 1024), cells, p, sum_map, level_map, rejected);
    return;
  }
  const Range range = Range::linear(static_cast<std::size_t>(total));
  launch("detect", "pfa_accumulate", range, cells, p, sum_map, level_map);
  launch("detect", "pfa_decide", range, cells, p, sum_map, level_map, rejected);
  launch("detect", "pfa_apply", range, cells, p, sum_map, level_map, rejected);
}

// Canonical compaction. GPUs: one work-group scans the cells in tiles (compact_group), one launch.
// Elsewhere: per-block counts, a one-work-item scan that also writes the count, then a per-block
// scatter. The order is the cell order whatever the device.
void OpenClBackend::compact_keypoints(const Buffer& cells, int total_cells, DeviceList out) {
  // Records past the items buffer are not written (the cpu backend would write past its end).
  const std::int64_t capacity = checks::compact_capacity(kBackend, cells, total_cells, out);
  const int total = std::max(total_cells, 0);
  if (work_groups()) {
    // Without items, the cell array stands in for the unused argument (nothing is written to it).
    const Buffer& items = capacity > 0 ? *out.items : cells;
    launch("detect", "compact_group", Range::linear(256, 256), cells, static_cast<cl_int>(total), items,
           static_cast<cl_uint>(capacity), *out.count, static_cast<cl_ulong>(out.count_offset_bytes));
    return;
  }

  const int num_blocks = (total + kCompactBlock - 1) / kCompactBlock;
  Buffer& blocks = scratch("compact_blocks", static_cast<std::size_t>(std::max(num_blocks, 1)) * 4);
  const Range per_block = Range::linear(static_cast<std::size_t>(num_blocks));
  launch("detect", "compact_count", per_block, cells, static_cast<cl_int>(total), static_cast<cl_int>(kCompactBlock),
         blocks);
  launch("detect", "compact_scan", Range::linear(1), blocks, static_cast<cl_int>(num_blocks), *out.count,
         static_cast<cl_ulong>(out.count_offset_bytes));
  if (capacity == 0) return;
  launch("detect", "compact_scatter", per_block, cells, static_cast<cl_int>(total), static_cast<cl_int>(kCompactBlock),
         blocks, *out.items, static_cast<cl_uint>(capacity));
}

// §3.3-§3.5 and the compaction. On a GPU (fused_detect()): FAST, culling and PFA's step A in one
// launch (fast_cull_group: no response plane), then PFA's other steps and the compaction in one
// work-group up to kPfaCompactGroupCells (pfa_compact_group), so an image is two launches where the
// four calls take four to six (NVIDIA's OpenCL costs the host ~5 us per enqueue); above, step B in
// a launch of its own (pfa_decide) between them: three. The same checks and the same bytes.
void OpenClBackend::detect_keypoints(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                                     Buffer& responses, const PyramidLayout& response_layout,
                                     const FastParams& fast, const CellLayout& cell_layout, Buffer& cells,
                                     const PfaParams* pfa, DeviceList out) {
  bool regular = true;
  for (const LevelCells& c : cell_layout.levels) regular = regular && c.cell_w > 0 && c.cell_h > 0;
  if (!fused_detect() || !regular || max_work_group() < kFastCullGroup) {
    Backend::detect_keypoints(pyramid, layout, lut, responses, response_layout, fast, cell_layout, cells, pfa, out);
    return;
  }
  check_fast(pyramid, layout, lut, responses, response_layout, fast);
  const std::int64_t end_cell = check_cull(responses, response_layout, cell_layout, cells);
  const int total = cell_layout.total_cells;
  const bool in_group = total >= 1 && max_work_group() >= 1024;  // pfa_compact_group can run
  // PFA's checks and scratch maps first: fast_cull_group does its step A where it writes every
  // cell PFA reads and pfa_compact_group finishes it.
  ClPfa p{};
  if (pfa != nullptr) p = check_pfa(cells, cell_layout, *pfa);
  const bool use_pfa = pfa != nullptr && p.total_cells > 0;
  const bool accumulate = use_pfa && in_group && end_cell == total && pfa_in_cull();
  const std::int64_t pixels0 = static_cast<std::int64_t>(std::max(p.width0, 1)) * std::max(p.height0, 1);
  // Without PFA or items, the cell array stands in for the unused buffers (nothing is written there).
  Buffer& sum_map = use_pfa ? scratch("pfa_sum", static_cast<std::size_t>(pixels0) * 4) : cells;
  Buffer& level_map = use_pfa ? scratch("pfa_levels", static_cast<std::size_t>(pixels0) * 4) : cells;
  if (end_cell > 0) {
    ClCells grid = to_cl(cell_layout);
    const checks::CellGroups groups = checks::plan_cell_groups(kBackend, "fast_cull_group", cell_layout, kFastCullGroup);
    for (std::size_t n = 0; n < groups.shift.size(); ++n) {
      grid.level[n].first_group = groups.first_group[n];
      grid.level[n].group_shift = groups.shift[n];
    }
    launch("detect", "fast_cull_group",
           Range::linear(static_cast<std::size_t>(groups.groups) * kFastCullGroup, kFastCullGroup), pyramid,
           to_cl(layout), lut, grid, static_cast<cl_int>(fast.threshold), static_cast<cl_int>(fast.edge),
           cells, static_cast<cl_int>(accumulate ? 1 : 0), p, sum_map, level_map);
  }
  const bool whole_pfa_in_group = use_pfa && !accumulate && total <= kPfaCompactGroupCells;
  if (!in_group || (use_pfa && !accumulate && !whole_pfa_in_group)) {
    if (use_pfa) pfa_filter(cells, cell_layout, *pfa);
    compact_keypoints(cells, total, out);
    return;
  }
  const std::int64_t capacity = checks::compact_capacity(kBackend, cells, total, out);
  Buffer& rejected = use_pfa ? scratch("pfa_rejected", static_cast<std::size_t>(total)) : cells;
  cl_int steps = whole_pfa_in_group ? kPfaAccumulate | kPfaDecide | kPfaApply
                 : use_pfa          ? kPfaDecide | kPfaApply
                                    : 0;
  if (use_pfa && total > kPfaCompactGroupCells) {  // step B over the cells, a work-item each
    launch("detect", "pfa_decide", Range::linear(static_cast<std::size_t>(total)), cells, p, sum_map,
           level_map, rejected);
    steps = kPfaApply;
  }
  const Buffer& items = capacity > 0 ? *out.items : cells;
  launch("detect", "pfa_compact_group", Range::linear(1024, 1024), cells, steps, p, sum_map, level_map,
         rejected, static_cast<cl_int>(total), items, static_cast<cl_uint>(capacity), *out.count,
         static_cast<cl_ulong>(out.count_offset_bytes));
}

}  // namespace porta::opencl
