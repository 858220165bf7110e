// Detection contracts of the CUDA backend (DESIGN.md §3.3-3.5): argument checks as the cpu
// backend's (backends/cpu/detect_kernels.cpp), the culling work split (MLPT, TEWA), then the
// launches of detect_kernels.cu. No host round-trips: PFA and compaction keep their state in
// device scratch memory.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "cuda/cull_plan.hpp"
#include "cuda/host_checks.hpp"
#include "porta/tables.hpp"

namespace porta::cuda {

using detail::fail;
using detail::require_bytes;
using detail::require_plane_inside;

namespace {

void check_same_level_sizes(const PyramidLayout& a, const PyramidLayout& b, const char* call) {
  bool same = a.num_levels() == b.num_levels();
  for (int n = 0; same && n < a.num_levels(); ++n)
    same = a.levels[static_cast<std::size_t>(n)].width == b.levels[static_cast<std::size_t>(n)].width &&
           a.levels[static_cast<std::size_t>(n)].height == b.levels[static_cast<std::size_t>(n)].height;
  if (!same) fail(call, "the two layouts do not have the same level sizes");
}

int ceil_div(int a, int b) { return (a + b - 1) / b; }

/// MLPT and TEWA for one level: a cell gets lanes_x threads across (at most one block) and as
/// many row bands as N_max requires and the block allows; a block takes as many such cells as fit.
CullLevel plan_cull_level(const Plane& plane, const LevelCells& grid, int nmax) {
  CullLevel c{};
  c.plane = detail::to_dev(plane);
  c.cell_w = grid.cell_w;
  c.cell_h = grid.cell_h;
  c.cols = grid.cols;
  c.rows = grid.rows;
  c.first_cell = grid.first_cell;
  const int w = std::max(grid.cell_w, 1), h = std::max(grid.cell_h, 1);
  c.lanes_x = std::min(w, kCullBlock);
  const int bands = std::clamp(ceil_div(h, nmax), 1, kCullBlock / c.lanes_x);
  c.band_rows = ceil_div(h, bands);
  c.cell_threads = c.lanes_x * bands;
  c.cells_per_block = kCullBlock / c.cell_threads;
  return c;
}

}  // namespace

CullLaunch plan_cull(const PyramidLayout& response_layout, const CellLayout& cell_layout, int nmax,
                     CullVariant variant) {
  CullLaunch launch{};
  launch.count = std::min(response_layout.num_levels(), static_cast<int>(cell_layout.levels.size()));
  launch.variant = variant == CullVariant::kMlptTewa    ? kCullMlptTewa
                   : variant == CullVariant::kMlptBlock ? kCullMlptBlock
                                                        : kCullLog2Block;
  std::int64_t blocks = 0;
  std::int64_t largest_cell = 1;
  for (int n = 0; n < launch.count; ++n) {
    const LevelCells& grid = cell_layout.levels[static_cast<std::size_t>(n)];
    launch.level[n] = plan_cull_level(response_layout.levels[static_cast<std::size_t>(n)], grid, nmax);
    if (variant != CullVariant::kMlptTewa) launch.level[n].cells_per_block = 1;
    launch.first_block[n] = static_cast<int>(blocks);
    blocks += ceil_div(grid.cols * grid.rows, launch.level[n].cells_per_block);
    largest_cell = std::max<std::int64_t>(largest_cell, static_cast<std::int64_t>(std::max(grid.cell_w, 1)) *
                                                            std::max(grid.cell_h, 1));
  }
  launch.first_block[launch.count] = static_cast<int>(blocks);
  int threads = 32;
  while (threads < 1024 && threads < largest_cell) threads *= 2;
  launch.block_threads = variant == CullVariant::kLog2Block ? threads : kCullBlock;
  return launch;
}

// §3.3: one launch over every pixel of every level.
void CudaBackend::fast_crf(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                           Buffer& responses, const PyramidLayout& response_layout,
                           const FastParams& params) {
  check_same_level_sizes(layout, response_layout, "fast_crf");
  checks::check_fast_edge(detail::kBackend, params);
  require_bytes(lut, 65536, "fast_crf", "the FAST table");
  for (const Plane& p : layout.levels) require_plane_inside(pyramid, p, 1, "fast_crf", "pyramid level");
  for (const Plane& p : response_layout.levels)
    require_plane_inside(responses, p, 2, "fast_crf", "response level");
  FastLaunch launch{};
  launch.src = detail::tile_levels(layout, "fast_crf");
  for (int n = 0; n < launch.src.count; ++n)
    launch.dst[n] = detail::to_dev(response_layout.levels[static_cast<std::size_t>(n)]);
  for (int i = 0; i < 16; ++i) {
    launch.dx[i] = kFastCircle[static_cast<std::size_t>(i)].first;
    launch.dy[i] = kFastCircle[static_cast<std::size_t>(i)].second;
  }
  launch.threshold = params.threshold;
  launch.edge = params.edge;
  if (launch.src.first_block[launch.src.count] == 0) return;
  activate();
  enqueue<&launch_fast_crf>("fast_crf", dev<std::uint8_t>(pyramid), dev<std::uint8_t>(lut),
                            dev<std::uint8_t>(responses), launch);
}

// §3.4: one launch over the cells of every level (MLPT + TEWA by default, see plan_cull_level;
// $PORTA_CUDA_CULL selects the ablation variants of plan_cull).
void CudaBackend::cull_cells(const Buffer& responses, const PyramidLayout& response_layout,
                             const CellLayout& cell_layout, Buffer& cells) {
  if (static_cast<int>(cell_layout.levels.size()) != response_layout.num_levels())
    fail("cull_cells", "the cell layout has " + std::to_string(cell_layout.levels.size()) +
                           " levels but the responses " + std::to_string(response_layout.num_levels()));
  detail::require_levels(response_layout.num_levels(), "cull_cells");
  std::int64_t end_cell = 0;
  for (const LevelCells& c : cell_layout.levels) {
    if (c.cols < 0 || c.rows < 0 || c.first_cell < 0)
      fail("cull_cells", "invalid cell grid (" + std::to_string(c.cols) + "x" + std::to_string(c.rows) +
                             " cells of " + std::to_string(c.cell_w) + "x" + std::to_string(c.cell_h) +
                             " from cell " + std::to_string(c.first_cell) + ")");
    end_cell = std::max(end_cell,
                        static_cast<std::int64_t>(c.first_cell) + static_cast<std::int64_t>(c.cols) * c.rows);
  }
  for (const Plane& p : response_layout.levels)
    require_plane_inside(responses, p, 2, "cull_cells", "response level");
  require_bytes(cells, end_cell * static_cast<std::int64_t>(sizeof(Keypoint)), "cull_cells",
                "the cell array");
  if (end_cell > std::numeric_limits<int>::max()) fail("cull_cells", "more than 2^31 cells");

  const CullLaunch launch = plan_cull(response_layout, cell_layout, mlpt_nmax(), cull_variant());
  if (launch.first_block[launch.count] == 0) return;
  activate();
  enqueue<&launch_cull_cells>("cull_cells", dev<std::uint8_t>(responses), launch, dev<DevKeypoint>(cells));
}

// §3.5: three launches over the cells (accumulate, decide, apply) with two level-0 sized scratch
// maps that are zero between calls (zero when allocated, restored by the last step).
void CudaBackend::pfa_filter(Buffer& cells, const CellLayout& cell_layout, const PfaParams& params) {
  const int width0 = params.level0_width, height0 = params.level0_height;
  if (width0 <= 0 || height0 <= 0)
    fail("pfa_filter",
         "level-0 size " + std::to_string(width0) + "x" + std::to_string(height0) + " is empty");
  // The cpu backend throws when it meets a keypoint of a level without a scale; the device cannot
  // throw, so every cell level must have one (cull_cells writes keypoints of those levels only).
  if (params.scales_q16.size() < cell_layout.levels.size())
    fail("pfa_filter", std::to_string(params.scales_q16.size()) + " level scales for " +
                           std::to_string(cell_layout.levels.size()) + " cell levels");
  const std::int64_t pixels0 = static_cast<std::int64_t>(width0) * height0;
  if (pixels0 > std::numeric_limits<std::uint32_t>::max() / 4)
    fail("pfa_filter",
         "level-0 size " + std::to_string(width0) + "x" + std::to_string(height0) + " is too large");
  const int total = cell_layout.total_cells;
  if (total <= 0) return;
  require_bytes(cells, static_cast<std::int64_t>(total) * static_cast<std::int64_t>(sizeof(Keypoint)),
                "pfa_filter", "the cell array");

  PfaLaunch launch{};
  launch.num_scales = static_cast<int>(std::min<std::size_t>(params.scales_q16.size(), kMaxLevels));
  for (int n = 0; n < launch.num_scales; ++n)
    launch.scales_q16[n] = params.scales_q16[static_cast<std::size_t>(n)];
  launch.width0 = width0;
  launch.height0 = height0;
  launch.reach = params.window / 2;
  launch.total_cells = total;
  activate();
  Buffer& sum_map = scratch("pfa.sum", static_cast<std::size_t>(pixels0) * 4);
  Buffer& level_map = scratch("pfa.levels", static_cast<std::size_t>(pixels0) * 4);
  Buffer& rejected = scratch("pfa.rejected", static_cast<std::size_t>(total));
  enqueue<&launch_pfa_filter>("pfa_filter", dev<DevKeypoint>(cells), launch, dev<std::uint32_t>(sum_map),
                              dev<std::uint32_t>(level_map), dev<std::uint8_t>(rejected));
}

// Canonical compaction: per-block counts, a one-block scan that also writes the count, then a
// per-block scatter with ballot ranks; the order is the cell order whatever the device.
void CudaBackend::compact_keypoints(const Buffer& cells, int total_cells, DeviceList out) {
  // Records past the items buffer are not written (the cpu backend would write past its end).
  const std::int64_t capacity = checks::compact_capacity(detail::kBackend, cells, total_cells, out);
  const int total = std::max(total_cells, 0);
  activate();
  const int blocks = (total + kCompactCellsPerBlock - 1) / kCompactCellsPerBlock;
  Buffer& block_scratch = scratch("compact.blocks", static_cast<std::size_t>(std::max(blocks, 1)) * 4);
  enqueue<&launch_compact>("compact_keypoints", static_cast<const DevKeypoint*>(dev<DevKeypoint>(cells)), total,
                           out.items ? dev<DevKeypoint>(*out.items) : static_cast<DevKeypoint*>(nullptr),
                           static_cast<std::uint32_t>(capacity),
                           dev<std::uint8_t>(*out.count, out.count_offset_bytes),
                           dev<std::uint32_t>(block_scratch));
}

}  // namespace porta::cuda
