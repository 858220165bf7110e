// Image kernels of the OpenCL backend: rectification, pyramid construction and the descriptor
// blur (DESIGN.md §3.1, §3.2, §3.7); device code in shaders/opencl/image.cl. Argument checks
// mirror the cpu backend's (backends/cpu/image_kernels.cpp); no host round-trips.
#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "opencl/cl_types.hpp"
#include "opencl/opencl_backend.hpp"
#include "porta/kernel_checks.hpp"

namespace porta::opencl {

namespace {

constexpr const char* kBackend = "opencl";
// Kernels take plane offsets as cl_int.
constexpr checks::PlaneLimits kImagePlanes{false, std::numeric_limits<cl_int>::max()};

}  // namespace

// §3.1: one work-item per destination pixel (image.cl rectify).
void OpenClBackend::rectify(const Buffer& src, const Plane& src_plane, const Buffer& map, Buffer& dst,
                            const Plane& dst_plane) {
  checks::check_rectify(kBackend, src, src_plane, map, dst, dst_plane, kImagePlanes);
  if (dst_plane.width <= 0 || dst_plane.height <= 0) return;
  // An empty source reads 0 everywhere: the kernel's bounds tests see width or height <= 0.
  ClPlane sp = to_cl(src_plane);
  if (src_plane.width <= 0 || src_plane.height <= 0) sp = {0, 0, 0, 0};
  launch("image", "rectify",
         Range::grid(static_cast<std::size_t>(dst_plane.width), static_cast<std::size_t>(dst_plane.height)), src, sp,
         map, dst, to_cl(dst_plane));
}

// §3.2. With $PORTA_OPENCL_FUSED_PYRAMID=on: levels 1..m in one launch, a 32 x 8 work-group per
// tile of them (build_pyramid_fused; m as far as each tile's regions fit in local memory, for 8
// levels at scale 1.2 all of them). The levels after m, and every level by default: one launch
// per level, in order (each level reads the one above; the queue is in order).
void OpenClBackend::build_pyramid(Buffer& pyramid, const PyramidLayout& layout, const Buffer& resize_table,
                                  const std::vector<std::int32_t>& level_offset) {
  const int levels = layout.num_levels();
  checks::check_pyramid(kBackend, pyramid, layout, resize_table, level_offset,
                        /*reject_negative_offsets=*/true, kImagePlanes);
  int first = 1;  // the first level built one launch per level
  if (fused_pyramid_ && levels > 2) {
    const int fused = fused_levels_(layout);
    if (fused >= 2) {
      PyramidLayout tiled = layout;  // tiles of levels 1..fused only
      for (int n = 0; n < levels; ++n)
        if (n == 0 || n > fused) tiled.levels[static_cast<std::size_t>(n)].width = 0;
      std::size_t tiles = 0;
      const ClTiles t = tiles_of(tiled, "build_pyramid", tiles);
      ClLevelInts offsets{};
      for (int n = 1; n <= fused; ++n) offsets.v[n] = level_offset[static_cast<std::size_t>(n - 1)];
      launch("image", "build_pyramid_fused", Range::tiles(tiles), pyramid, to_cl(layout), resize_table, t, offsets);
      first = fused + 1;
    }
  }
  for (int n = first; n < levels; ++n) {
    const Plane& above = layout.levels[static_cast<std::size_t>(n - 1)];
    const Plane& level = layout.levels[static_cast<std::size_t>(n)];
    if (level.width <= 0 || level.height <= 0) continue;
    launch("image", "build_pyramid_level",
           Range::grid(static_cast<std::size_t>(level.width), static_cast<std::size_t>(level.height)), pyramid,
           to_cl(above), to_cl(level), resize_table, static_cast<cl_int>(level_offset[static_cast<std::size_t>(n - 1)]));
  }
}

// §3.7. GPUs: one launch over the 32 x 8 tiles of all levels, both passes through local memory
// (blur_tiled). Elsewhere, or in place: two launches over all levels, the horizontal pass into a
// packed uint16 scratch plane per level ("blur_h"), then the vertical pass into `blurred`.
void OpenClBackend::blur(const Buffer& pyramid, const PyramidLayout& layout, Buffer& blurred,
                         const std::array<std::int32_t, 7>& taps) {
  checks::check_blur(kBackend, pyramid, layout, blurred, taps, kImagePlanes);
  if (work_groups() && &pyramid != &blurred) {
    std::size_t tiles = 0;
    const ClTiles t = tiles_of(layout, "blur", tiles);
    if (tiles == 0) return;
    ClLevelInts cl_taps{};
    for (int k = 0; k < 7; ++k) cl_taps.v[k] = taps[static_cast<std::size_t>(k)];
    launch("image", "blur_tiled", Range::tiles(tiles), pyramid, to_cl(layout), blurred, t, cl_taps);
    return;
  }
  ClLevels cl_layout = to_cl(layout);
  ClLevelInts scratch_offset{};
  std::int64_t elements = 0;
  std::size_t rows = 0;
  for (int n = 0; n < layout.num_levels(); ++n) {
    const Plane& level = layout.levels[static_cast<std::size_t>(n)];
    if (level.width <= 0 || level.height <= 0) {  // nothing to blur: no rows for this level
      cl_layout.level[n].width = 0;
      cl_layout.level[n].height = 0;
      continue;
    }
    scratch_offset.v[n] = static_cast<cl_int>(elements);
    elements += static_cast<std::int64_t>(level.width) * level.height;
    if (elements > std::numeric_limits<cl_int>::max())
      throw BackendError("opencl: blur: the pyramid has more than 2^31 pixels");
    rows += static_cast<std::size_t>(level.height);
  }
  if (elements == 0) return;
  ClLevelInts cl_taps{};
  for (int k = 0; k < 7; ++k) cl_taps.v[k] = taps[static_cast<std::size_t>(k)];
  Buffer& horizontal = scratch("blur_h", static_cast<std::size_t>(elements) * 2);
  const Range range = Range::linear(rows);
  launch("image", "blur_horizontal", range, pyramid, cl_layout, horizontal, scratch_offset, cl_taps);
  launch("image", "blur_vertical", range, horizontal, cl_layout, blurred, scratch_offset, cl_taps);
}

}  // namespace porta::opencl
