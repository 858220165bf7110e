// Detection kernels of the Vulkan backend: FAST corner response, per-cell culling, pyramidal
// feature aggregation (PFA) and the canonical compaction of the cell array (DESIGN.md §3.3-3.5);
// shaders fast_crf.comp, cull_cells.comp, pfa_*.comp, compact_*.comp. No host round-trips: PFA and
// compaction keep their intermediate state in device scratch memory.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "vulkan/vk_runtime.hpp"
#include "vulkan/vk_types.hpp"
#include "vulkan/vulkan_backend.hpp"

namespace porta::vulkan {

namespace {

struct FastCrfParams {  // fast_crf.comp (parameter buffer)
  GlslLevels src, dst;
  std::int32_t eps, edge, pad[2];
};
struct FastTiledParams {  // fast_tiled.comp (parameter buffer)
  GlslLevels src, dst;
  GlslTiles tiles;
  std::int32_t eps, edge, pad[2];
};
struct CullCellsParams {  // cull_cells.comp and cull_cells_small.comp (parameter buffer)
  GlslLevels layout;
  GlslCells cells;
  std::int32_t end_cell, pad[3];  // cull_cells_small.comp only
};
/// Cells of at most this many pixels are culled one invocation per cell (cull_cells_small.comp):
/// a 64-wide workgroup and its barriers for a handful of pixels cost far more than the scan.
constexpr std::int64_t kSmallCellPixels = 256;
struct PfaStepParams {  // pfa_accumulate/decide/apply.comp (push constants)
  std::int32_t scales[kMaxLevels];
  std::int32_t total_cells, num_scales, width0, height0, reach, pad[3];
};
struct CompactParams {  // compact_count/scan/scatter.comp (push constants)
  std::uint32_t total_cells, block, capacity, num_blocks, count_offset, pad[3];
};
struct CompactGroupParams {  // compact_group.comp (push constants)
  std::uint32_t total_cells, capacity, count_offset;
};
static_assert(sizeof(PfaStepParams) <= kMaxPushBytes && sizeof(CompactParams) <= kMaxPushBytes);

constexpr std::uint32_t kCompactBlock = 128;  // cells per invocation of the compaction
/// PFA runs in one workgroup (pfa_group) up to this many cells, in three dispatches above: on the
/// H200 one workgroup took 6 µs for 70 cells against 13 for the three dispatches, but 28 against
/// 15 for ~1 500 (its steps then loop, each a chain of dependent loads on one multiprocessor).
/// Likewise in detect_keypoints: up to this many cells PFA's step B runs in the compaction's
/// workgroup (pfa_compact_group.comp, or fast_cull_finish.comp's last workgroup), above in
/// pfa_decide.comp's dispatch (on the H100 one workgroup took 22.4 against 5.5 + 9.8 µs for the
/// ~2 800 cells of 752x480 with 8 levels), while step C and the compaction stay in the workgroup
/// whatever the count.
constexpr int kPfaGroupCells = 512;

/// The compaction's checks of its arguments (the count's offset is a uint32 in the shaders);
/// returns the records the items buffer holds (checks::compact_capacity).
std::int64_t check_compact(const Buffer& cells, int total_cells, const DeviceList& out) {
  if (out.count != nullptr &&
      (out.count_offset_bytes < 0 || out.count_offset_bytes > std::numeric_limits<std::int32_t>::max()))
    throw BackendError("vulkan: compact_keypoints: count offset " + std::to_string(out.count_offset_bytes) +
                       " is out of range");
  return checks::compact_capacity(kBackend, cells, total_cells, out);
}

/// fast_crf's checks of its arguments.
void check_fast(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut, const Buffer& responses,
                const PyramidLayout& response_layout, const porta::FastParams& params) {
  checks::check_fast(kBackend, pyramid, layout, lut, responses, response_layout, params, kPlaneLimits);
}

/// cull_cells' checks of its arguments (cells of at most 2^24 pixels: the shaders' index); returns
/// the end of the last cell grid (the cells it writes).
std::int64_t check_cull(const Buffer& responses, const PyramidLayout& response_layout, const CellLayout& cell_layout,
                        const Buffer& cells) {
  return checks::check_cull(kBackend, responses, response_layout, cell_layout, cells, std::int64_t{1} << 24,
                            kPlaneLimits);
}

/// pfa_filter's checks of its arguments; returns the shaders' parameters (total_cells 0: nothing
/// to do). The maps are indexed with 32-bit signed offsets of 4-byte entries.
PfaStepParams check_pfa(const Buffer& cells, const CellLayout& cell_layout, const porta::PfaParams& params) {
  const checks::PfaSetup setup = checks::check_pfa(kBackend, cells, cell_layout, params,
                                                   std::numeric_limits<std::int32_t>::max() / 4);
  PfaStepParams p{};
  for (int n = 0; n < setup.num_scales; ++n) p.scales[n] = setup.scales[static_cast<std::size_t>(n)];
  p.total_cells = setup.total_cells;
  p.num_scales = setup.num_scales;
  p.width0 = setup.width0;
  p.height0 = setup.height0;
  p.reach = setup.reach;
  return p;
}

struct FastCullParams {  // fast_cull.comp (parameter buffer)
  GlslLevels layout;
  GlslCells cells;
  std::int32_t eps, edge, pad[2];
  // PFA's step A in the same dispatch (accumulate != 0): PfaStepParams' fields.
  std::int32_t scales[kMaxLevels];
  std::int32_t num_scales, width0, height0, accumulate;
};
// fast_cull_finish.comp (parameter buffer): fast_cull's, then its last workgroup's.
struct FastCullFinishParams {
  FastCullParams cull;
  std::int32_t reach, total_cells;
  std::uint32_t pfa_steps, capacity, count_offset;
  std::int32_t pad[3];
};
struct PfaCompactParams {  // pfa_compact_group.comp (push constants): PFA's, then the compaction's
  PfaStepParams pfa;
  std::uint32_t pfa_steps, capacity, count_offset;
};
static_assert(sizeof(PfaCompactParams) <= kMaxPushBytes);
/// pfa_compact_group.comp's pfa_steps: which of PFA's steps it runs.
constexpr std::uint32_t kPfaAccumulate = 1, kPfaDecide = 2, kPfaApply = 4;
/// fast_cull.comp's workgroup size (its GROUP).
constexpr int kFastCullGroup = 256;

}  // namespace

// §3.3, one dispatch. GPUs: one workgroup per 32 x 8 tile of any level, the tile read once into
// shared memory (fast_tiled.comp). Elsewhere: one invocation per row of every level (rows of all
// levels end to end).
void VulkanBackend::fast_crf(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                             Buffer& responses, const PyramidLayout& response_layout,
                             const porta::FastParams& params) {
  check_fast(pyramid, layout, lut, responses, response_layout, params);
  if (work_groups()) {
    FastTiledParams t{};
    t.src = to_glsl(layout, "fast_crf");
    t.dst = to_glsl(response_layout, "fast_crf");
    std::uint64_t tiles = 0;
    t.tiles = tiles_of(layout, "fast_crf", tiles);
    t.eps = params.threshold;
    t.edge = params.edge;
    rt().dispatch("fast_tiled", {&pyramid, &lut, &responses}, t, Work::groups(tiles));
    return;
  }
  FastCrfParams p{};
  std::uint64_t max_width = 0, rows = 0;
  p.src = rows_of_levels(layout, "fast_crf", max_width, rows);
  p.dst = to_glsl(response_layout, "fast_crf");
  p.eps = params.threshold;
  p.edge = params.edge;
  rt().dispatch("fast_crf", {&pyramid, &lut, &responses}, p, Work::items(rows));
}

// §3.4: one workgroup per cell of every level, one dispatch; the workgroup reduces the cell
// through shared memory (no subgroup operations, so any subgroup size gives the same bytes).
// Small cells, and any cells on CPU devices (lavapipe, where a workgroup's barriers cost more than
// the scan): one invocation per cell instead (cull_cells_small.comp), the same bytes.
void VulkanBackend::cull_cells(const Buffer& responses, const PyramidLayout& response_layout,
                               const CellLayout& cell_layout, Buffer& cells) {
  const std::int64_t end_cell = check_cull(responses, response_layout, cell_layout, cells);
  std::int64_t largest_cell = 0;
  for (const LevelCells& c : cell_layout.levels)
    largest_cell = std::max(largest_cell, static_cast<std::int64_t>(c.cell_w) * c.cell_h);
  const CullCellsParams p{to_glsl(response_layout, "cull_cells"), to_glsl(cell_layout, "cull_cells"),
                          static_cast<std::int32_t>(end_cell), {0, 0, 0}};
  if (largest_cell <= kSmallCellPixels || !work_groups()) {
    rt().dispatch("cull_cells_small", {&responses, &cells}, p, Work::items(static_cast<std::uint64_t>(end_cell)));
  } else {
    rt().dispatch("cull_cells", {&responses, &cells}, p, Work::groups(static_cast<std::uint64_t>(end_cell)));
  }
}

// §3.5: three steps over the cells (accumulate with order-independent atomics, decide, apply) with
// two level-0 sized scratch maps that are zero between calls (zero when allocated, restored by the
// last step). GPUs, a few hundred cells: all three in one workgroup (pfa_group.comp); otherwise
// three dispatches.
void VulkanBackend::pfa_filter(Buffer& cells, const CellLayout& cell_layout, const porta::PfaParams& params) {
  const PfaStepParams p = check_pfa(cells, cell_layout, params);
  const int total = p.total_cells;
  if (total <= 0) return;
  const std::int64_t pixels0 = static_cast<std::int64_t>(p.width0) * p.height0;
  Buffer& sum_map = scratch("pfa_sum", static_cast<std::size_t>(pixels0) * 4);
  Buffer& level_map = scratch("pfa_levels", static_cast<std::size_t>(pixels0) * 4);
  Buffer& rejected = scratch("pfa_rejected", static_cast<std::size_t>(total));
  const VkPhysicalDeviceLimits& limits = rt().context().limits();
  if (work_groups() && total <= kPfaGroupCells && limits.maxComputeWorkGroupInvocations >= 1024 &&
      limits.maxComputeWorkGroupSize[0] >= 1024) {
    rt().dispatch("pfa_group", {&cells, &sum_map, &level_map, &rejected}, p, Work::groups(1));
    return;
  }
  const Work work = Work::items(static_cast<std::uint64_t>(total));
  rt().dispatch("pfa_accumulate", {&cells, &sum_map, &level_map, &rejected}, p, work);
  rt().dispatch("pfa_decide", {&cells, &sum_map, &level_map, &rejected}, p, work);
  rt().dispatch("pfa_apply", {&cells, &sum_map, &level_map, &rejected}, p, work);
}

// Canonical compaction: per-block counts, a one-invocation scan that also writes the count, then a
// per-block scatter; the order is the cell order whatever the device.
void VulkanBackend::compact_keypoints(const Buffer& cells, int total_cells, DeviceList out) {
  // Records past the items buffer are not written (the cpu backend would write past its end).
  const std::int64_t capacity = check_compact(cells, total_cells, out);
  const int total = std::max(total_cells, 0);

  // Without items, the cell array stands in for the unused items binding.
  const Buffer* items = capacity > 0 ? out.items : &cells;
  const VkPhysicalDeviceLimits& limits = rt().context().limits();
  if (work_groups() && limits.maxComputeWorkGroupInvocations >= 256 && limits.maxComputeWorkGroupSize[0] >= 256) {
    // GPUs: one workgroup scans the cells in tiles (compact_group.comp), one dispatch instead of three.
    const CompactGroupParams g{static_cast<std::uint32_t>(total), static_cast<std::uint32_t>(capacity),
                               static_cast<std::uint32_t>(out.count_offset_bytes)};
    rt().dispatch("compact_group", {&cells, items, out.count}, g, Work::groups(1));
    return;
  }
  const std::uint32_t num_blocks = (static_cast<std::uint32_t>(total) + kCompactBlock - 1) / kCompactBlock;
  Buffer& blocks =
      scratch("compact_blocks", static_cast<std::size_t>(std::max<std::uint32_t>(num_blocks, 1)) * 4);
  const CompactParams p{static_cast<std::uint32_t>(total),
                        kCompactBlock,
                        static_cast<std::uint32_t>(capacity),
                        num_blocks,
                        static_cast<std::uint32_t>(out.count_offset_bytes),
                        {0, 0, 0}};
  rt().dispatch("compact_count", {&cells, &blocks, items, out.count}, p, Work::items(num_blocks));
  rt().dispatch("compact_scan", {&cells, &blocks, items, out.count}, p, Work::items(1));
  if (capacity > 0)
    rt().dispatch("compact_scatter", {&cells, &blocks, items, out.count}, p, Work::items(num_blocks));
}

// §3.3-§3.5 and the compaction. On a GPU (fused_detect()): FAST, culling and PFA's step A in one
// dispatch (fast_cull.comp: no response plane), then PFA's other steps and the compaction in one
// workgroup for a few hundred cells (pfa_compact_group.comp): two dispatches where the four calls
// take six. For more cells, step B in a dispatch of its own (pfa_decide.comp) between them:
// three. The same checks and the same bytes.
void VulkanBackend::detect_keypoints(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                                     Buffer& responses, const PyramidLayout& response_layout,
                                     const porta::FastParams& fast, const CellLayout& cell_layout, Buffer& cells,
                                     const porta::PfaParams* pfa, DeviceList out) {
  if (!fused_detect()) {
    Backend::detect_keypoints(pyramid, layout, lut, responses, response_layout, fast, cell_layout, cells, pfa, out);
    return;
  }
  check_fast(pyramid, layout, lut, responses, response_layout, fast);
  const std::int64_t end_cell = check_cull(responses, response_layout, cell_layout, cells);
  const int total = cell_layout.total_cells;
  // PFA's checks and scratch maps first: fast_cull does its step A where it writes every cell
  // PFA reads.
  PfaCompactParams g{};
  if (pfa != nullptr) g.pfa = check_pfa(cells, cell_layout, *pfa);
  const bool use_pfa = pfa != nullptr && g.pfa.total_cells > 0;
  const bool accumulate = use_pfa && end_cell == total && pfa_in_cull();
  const bool whole_pfa_in_group = use_pfa && !accumulate && total <= kPfaGroupCells;
  const std::int64_t pixels0 =
      static_cast<std::int64_t>(std::max(g.pfa.width0, 1)) * std::max(g.pfa.height0, 1);
  // Without PFA or items, the cell array stands in for the unused bindings (nothing is written there).
  Buffer& sum_map = use_pfa ? scratch("pfa_sum", static_cast<std::size_t>(pixels0) * 4) : cells;
  Buffer& level_map = use_pfa ? scratch("pfa_levels", static_cast<std::size_t>(pixels0) * 4) : cells;
  // Up to kPfaGroupCells cells (fused_detect_finish()): fast_cull's last workgroup does PFA's other
  // steps and the compaction (fast_cull_finish.comp), one dispatch in all.
  const bool finish = fused_detect_finish() && end_cell == total && total >= 1 && total <= kPfaGroupCells &&
                      (accumulate || !use_pfa);
  if (end_cell > 0) {
    FastCullParams f{};
    f.layout = to_glsl(layout, "fast_crf");
    f.cells = to_glsl(cell_layout, "cull_cells");
    f.eps = fast.threshold;
    f.edge = fast.edge;
    const checks::CellGroups groups =
        checks::plan_cell_groups(kBackend, "fast_cull", cell_layout, kFastCullGroup, cull_pixels());
    for (std::size_t n = 0; n < groups.shift.size(); ++n) {
      f.cells.level[n].first_group = groups.first_group[n];
      f.cells.level[n].group_shift = groups.shift[n];
    }
    if (accumulate) {
      std::copy(std::begin(g.pfa.scales), std::end(g.pfa.scales), std::begin(f.scales));
      f.num_scales = g.pfa.num_scales;
      f.width0 = g.pfa.width0;
      f.height0 = g.pfa.height0;
      f.accumulate = 1;
    }
    if (finish) {
      const std::int64_t capacity = check_compact(cells, total, out);
      FastCullFinishParams e{};
      e.cull = f;
      e.reach = g.pfa.reach;
      e.total_cells = total;
      e.pfa_steps = use_pfa ? kPfaDecide | kPfaApply : 0u;
      e.capacity = static_cast<std::uint32_t>(capacity);
      e.count_offset = static_cast<std::uint32_t>(out.count_offset_bytes);
      // Without PFA or items, the cell array stands in for the unused bindings (nothing is written there).
      Buffer& rejected = use_pfa ? scratch("pfa_rejected", static_cast<std::size_t>(total)) : cells;
      const Buffer* items = capacity > 0 ? out.items : &cells;
      Buffer& finished = scratch("fast_cull_finished", 4);  // zero when made; the last workgroup resets it
      rt().dispatch("fast_cull_finish",
                    {&pyramid, &lut, &cells, &sum_map, &level_map, &rejected, items, out.count, &finished}, e,
                    Work::groups(static_cast<std::uint64_t>(groups.groups)));
      return;
    }
    rt().dispatch("fast_cull", {&pyramid, &lut, &cells, &sum_map, &level_map}, f,
                  Work::groups(static_cast<std::uint64_t>(groups.groups)));
  }
  if (total < 1) {
    compact_keypoints(cells, total, out);
    return;
  }
  if (use_pfa && !accumulate && !whole_pfa_in_group) {  // PFA as pfa_filter runs it
    pfa_filter(cells, cell_layout, *pfa);
    compact_keypoints(cells, total, out);
    return;
  }
  const std::int64_t capacity = check_compact(cells, total, out);
  Buffer& rejected = use_pfa ? scratch("pfa_rejected", static_cast<std::size_t>(total)) : cells;
  if (whole_pfa_in_group) {
    g.pfa_steps = kPfaAccumulate | kPfaDecide | kPfaApply;
  } else if (use_pfa && total > kPfaGroupCells) {  // step B over the cells, an invocation each
    rt().dispatch("pfa_decide", {&cells, &sum_map, &level_map, &rejected}, g.pfa,
                  Work::items(static_cast<std::uint64_t>(total)));
    g.pfa_steps = kPfaApply;
  } else {
    g.pfa_steps = use_pfa ? kPfaDecide | kPfaApply : 0u;
  }
  g.pfa.total_cells = total;  // the compaction's count whether or not PFA runs
  g.capacity = static_cast<std::uint32_t>(capacity);
  g.count_offset = static_cast<std::uint32_t>(out.count_offset_bytes);
  const Buffer* items = capacity > 0 ? out.items : &cells;
  rt().dispatch("pfa_compact_group", {&cells, &sum_map, &level_map, &rejected, items, out.count}, g,
                Work::groups(1));
}

}  // namespace porta::vulkan
