// Image kernels of the Vulkan backend: rectification, pyramid construction and the descriptor
// blur (DESIGN.md §3.1, §3.2, §3.7); shaders rectify.comp, build_pyramid.comp, blur_*.comp.
// Argument checks mirror the cpu backend's (backends/cpu/image_kernels.cpp).
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "vulkan/vk_runtime.hpp"
#include "vulkan/vk_types.hpp"
#include "vulkan/vulkan_backend.hpp"

namespace porta::vulkan {

namespace {

struct RectifyParams {  // rectify.comp (push constants)
  GlslPlane src, dst;
};
struct PyramidParams {  // build_pyramid.comp (push constants)
  GlslPlane above, level;
  std::int32_t table_offset, pad[3];
};
struct PyramidFusedParams {  // build_pyramid_fused.comp (parameter buffer)
  GlslLevels layout;
  GlslTiles tiles;
  std::int32_t table_offset[kMaxLevels];
};
static_assert(sizeof(PyramidFusedParams) == 208 + 112 + 48);
struct BlurParams {  // blur_horizontal.comp, blur_vertical.comp (parameter buffer)
  GlslLevels layout;
  std::int32_t scratch_offset[kMaxLevels];
  std::int32_t taps[kMaxLevels];
};
static_assert(sizeof(BlurParams) == 208 + 48 + 48);
struct BlurTiledParams {  // blur_tiled.comp (parameter buffer)
  GlslLevels layout;
  GlslTiles tiles;
  std::int32_t taps[8];
};
static_assert(sizeof(BlurTiledParams) == 208 + 112 + 32);

}  // namespace

// §3.1: one invocation per destination pixel.
void VulkanBackend::rectify(const Buffer& src, const Plane& src_plane, const Buffer& map, Buffer& dst,
                            const Plane& dst_plane) {
  checks::check_rectify(kBackend, src, src_plane, map, dst, dst_plane, kPlaneLimits);
  if (dst_plane.width <= 0 || dst_plane.height <= 0) return;
  const std::int64_t map_bytes = static_cast<std::int64_t>(dst_plane.width) * dst_plane.height * 2 * 4;
  if (map_bytes / 4 > std::numeric_limits<std::int32_t>::max())
    throw BackendError("vulkan: rectify: the map has more than 2^31 entries");
  // An empty source reads 0 everywhere: the shader's bounds tests see width or height 0.
  RectifyParams params{to_glsl(src_plane), to_glsl(dst_plane)};
  if (src_plane.width <= 0 || src_plane.height <= 0) params.src = {0, 0, 0, 0};
  rt().dispatch(
      "rectify", {&src, &map, &dst}, params,
      Work::grid(static_cast<std::uint64_t>(dst_plane.width), static_cast<std::uint64_t>(dst_plane.height)));
}

// §3.2. With $PORTA_VULKAN_FUSED_PYRAMID=on: levels 1..m in one dispatch, one workgroup per
// 32 x 8 tile of them (build_pyramid_fused.comp; m as far as each tile's regions fit in shared
// memory, for 8 levels at scale 1.2 all of them). The levels after m, and every level by default:
// one dispatch per level, in order (each reads the level above; barriers between them), 32 x 8
// workgroups on GPUs, 8 x 8 elsewhere.
void VulkanBackend::build_pyramid(Buffer& pyramid, const PyramidLayout& layout, const Buffer& resize_table,
                                  const std::vector<std::int32_t>& level_offset) {
  const int levels = layout.num_levels();
  checks::check_pyramid(kBackend, pyramid, layout, resize_table, level_offset, /*reject_negative_offsets=*/true,
                        kPlaneLimits);
  int first = 1;  // the first level built one dispatch per level
  if (fused_pyramid_ && levels > 2) {
    const int fused = fused_levels_(layout);
    if (fused >= 2) {
      PyramidFusedParams params{};
      params.layout = to_glsl(layout, "build_pyramid");
      PyramidLayout tiled = layout;  // tiles of levels 1..fused only
      for (int n = 0; n < levels; ++n)
        if (n == 0 || n > fused) tiled.levels[static_cast<std::size_t>(n)].width = 0;
      std::uint64_t tiles = 0;
      params.tiles = tiles_of(tiled, "build_pyramid", tiles);
      for (int n = 1; n <= fused; ++n) params.table_offset[n] = level_offset[static_cast<std::size_t>(n - 1)];
      rt().dispatch("build_pyramid_fused", {&pyramid, &resize_table}, params, Work::groups(tiles));
      first = fused + 1;
    }
  }
  for (int n = first; n < levels; ++n) {
    const Plane& above = layout.levels[static_cast<std::size_t>(n - 1)];
    const Plane& level = layout.levels[static_cast<std::size_t>(n)];
    if (level.width <= 0 || level.height <= 0) continue;
    const PyramidParams params{
        to_glsl(above), to_glsl(level), level_offset[static_cast<std::size_t>(n - 1)], {0, 0, 0}};
    rt().dispatch(
        work_groups() ? "build_pyramid_wide" : "build_pyramid", {&pyramid, &resize_table}, params,
        Work::grid(static_cast<std::uint64_t>(level.width), static_cast<std::uint64_t>(level.height)));
  }
}


// §3.7. GPUs: one dispatch over the 32 x 8 tiles of all levels, both passes through shared memory
// (blur_tiled.comp). Elsewhere, or in place: two dispatches over all levels, the horizontal pass
// into a packed uint16 scratch plane per level ("blur_h"), then the vertical pass into `blurred`.
void VulkanBackend::blur(const Buffer& pyramid, const PyramidLayout& layout, Buffer& blurred,
                         const std::array<std::int32_t, 7>& taps) {
  checks::check_blur(kBackend, pyramid, layout, blurred, taps, kPlaneLimits);
  if (work_groups() && &pyramid != &blurred) {
    BlurTiledParams params{};
    params.layout = to_glsl(layout, "blur");
    std::uint64_t tiles = 0;
    params.tiles = tiles_of(layout, "blur", tiles);
    for (int k = 0; k < 7; ++k) params.taps[k] = taps[static_cast<std::size_t>(k)];
    rt().dispatch("blur_tiled", {&pyramid, &blurred}, params, Work::groups(tiles));
    return;
  }
  BlurParams params{};
  std::uint64_t max_width = 0, rows = 0;
  params.layout = rows_of_levels(layout, "blur", max_width, rows);
  std::int64_t elements = 0;
  for (int n = 0; n < params.layout.count; ++n) {
    const GlslPlane& p = params.layout.level[n];
    params.scratch_offset[n] = static_cast<std::int32_t>(elements);
    elements += static_cast<std::int64_t>(p.width) * p.height;
    if (elements * 2 > std::numeric_limits<std::int32_t>::max())
      throw BackendError("vulkan: blur: the pyramid has more than 2^30 pixels");
  }
  if (elements == 0) return;
  for (int k = 0; k < 7; ++k) params.taps[k] = taps[static_cast<std::size_t>(k)];
  Buffer& horizontal = scratch("blur_h", static_cast<std::size_t>(elements) * 2);
  rt().dispatch("blur_horizontal", {&pyramid, &horizontal}, params, Work::items(rows));
  rt().dispatch("blur_vertical", {&horizontal, &blurred}, params, Work::items(rows));
}

}  // namespace porta::vulkan
