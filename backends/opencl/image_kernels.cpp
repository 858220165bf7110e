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

namespace porta::opencl {

namespace {

// A kernel reading or writing outside its buffer would corrupt device memory silently; say which.
void require_plane_inside(const Buffer& buffer, const Plane& plane, int element_bytes, const char* kernel,
                          const char* what) {
  if (plane.width <= 0 || plane.height <= 0) return;
  const std::int64_t end_bytes =
      plane.offset_bytes +
      (static_cast<std::int64_t>(plane.height - 1) * plane.pitch + plane.width) * element_bytes;
  if (plane.offset_bytes < 0 || plane.pitch < plane.width ||
      end_bytes > static_cast<std::int64_t>(buffer.size_bytes()) ||
      plane.offset_bytes > std::numeric_limits<cl_int>::max())
    throw BackendError(std::string("opencl: ") + kernel + ": " + what + " plane (offset " +
                       std::to_string(plane.offset_bytes) + " bytes, " + std::to_string(plane.width) + "x" +
                       std::to_string(plane.height) + ", pitch " + std::to_string(plane.pitch) +
                       ") does not fit its buffer of " + std::to_string(buffer.size_bytes()) + " bytes");
}

void require_bytes(const Buffer& buffer, std::int64_t bytes, const char* kernel, const std::string& what) {
  if (bytes > static_cast<std::int64_t>(buffer.size_bytes()))
    throw BackendError(std::string("opencl: ") + kernel + ": " + what + " needs " + std::to_string(bytes) +
                       " bytes but its buffer has " + std::to_string(buffer.size_bytes()));
}

}  // namespace

// §3.1: one work-item per destination pixel (image.cl rectify).
void OpenClBackend::rectify(const Buffer& src, const Plane& src_plane, const Buffer& map, Buffer& dst,
                            const Plane& dst_plane) {
  require_plane_inside(src, src_plane, 1, "rectify", "source");
  require_plane_inside(dst, dst_plane, 1, "rectify", "destination");
  require_bytes(map, static_cast<std::int64_t>(dst_plane.width) * dst_plane.height * 2 * 4, "rectify",
                "the map");
  if (dst_plane.width <= 0 || dst_plane.height <= 0) return;
  // An empty source reads 0 everywhere: the kernel's bounds tests see width or height <= 0.
  ClPlane sp = to_cl(src_plane);
  if (src_plane.width <= 0 || src_plane.height <= 0) sp = {0, 0, 0, 0};
  launch("image", "rectify",
         Range::grid(static_cast<std::size_t>(dst_plane.width), static_cast<std::size_t>(dst_plane.height)), src, sp,
         map, dst, to_cl(dst_plane));
}

// §3.2: one launch per level, in order (each level reads the one above; the queue is in order).
void OpenClBackend::build_pyramid(Buffer& pyramid, const PyramidLayout& layout, const Buffer& resize_table,
                                  const std::vector<std::int32_t>& level_offset) {
  const int levels = layout.num_levels();
  if (levels > 1 && static_cast<int>(level_offset.size()) < levels - 1)
    throw BackendError("opencl: build_pyramid: " + std::to_string(level_offset.size()) +
                       " level offsets given for " + std::to_string(levels) + " levels (need levels - 1)");
  for (int n = 0; n < levels; ++n)
    require_plane_inside(pyramid, layout.levels[static_cast<std::size_t>(n)], 1, "build_pyramid", "level");
  for (int n = 1; n < levels; ++n) {
    const Plane& level = layout.levels[static_cast<std::size_t>(n)];
    const std::int64_t offset = level_offset[static_cast<std::size_t>(n - 1)];
    const std::int64_t table_end = offset + 2 * static_cast<std::int64_t>(level.width) + 2 * level.height;
    require_bytes(resize_table, table_end * 4, "build_pyramid", "the resize table of level " + std::to_string(n));
    if (offset < 0)
      throw BackendError("opencl: build_pyramid: negative resize table offset " + std::to_string(offset) +
                         " for level " + std::to_string(n));
  }
  for (int n = 1; n < levels; ++n) {
    const Plane& above = layout.levels[static_cast<std::size_t>(n - 1)];
    const Plane& level = layout.levels[static_cast<std::size_t>(n)];
    if (level.width <= 0 || level.height <= 0) continue;
    launch("image", "build_pyramid_level",
           Range::grid(static_cast<std::size_t>(level.width), static_cast<std::size_t>(level.height)), pyramid,
           to_cl(above), to_cl(level), resize_table, static_cast<cl_int>(level_offset[static_cast<std::size_t>(n - 1)]));
  }
}

// §3.7: two launches over all levels, the horizontal pass into a packed uint16 scratch plane per
// level ("blur_h"), then the vertical pass into `blurred`.
void OpenClBackend::blur(const Buffer& pyramid, const PyramidLayout& layout, Buffer& blurred,
                         const std::array<std::int32_t, 7>& taps) {
  std::int32_t tap_sum = 0;
  for (const std::int32_t t : taps) {
    if (t < 0) throw BackendError("opencl: blur: taps must be non-negative (see build_blur_taps())");
    tap_sum += t;
  }
  if (tap_sum != 256)
    throw BackendError("opencl: blur: taps sum to " + std::to_string(tap_sum) +
                       ", must sum to 256 (see build_blur_taps())");
  for (const Plane& level : layout.levels) {
    require_plane_inside(pyramid, level, 1, "blur", "pyramid level");
    require_plane_inside(blurred, level, 1, "blur", "blurred level");
  }
  ClLevels cl_layout = to_cl(layout);
  ClLevelInts scratch_offset{};
  std::int64_t elements = 0;
  std::size_t max_width = 0, rows = 0;
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
    max_width = std::max(max_width, static_cast<std::size_t>(level.width));
    rows += static_cast<std::size_t>(level.height);
  }
  if (elements == 0) return;
  ClLevelInts cl_taps{};
  for (int k = 0; k < 7; ++k) cl_taps.v[k] = taps[static_cast<std::size_t>(k)];
  Buffer& horizontal = scratch("blur_h", static_cast<std::size_t>(elements) * 2);
  const Range range = Range::grid(max_width, rows);
  launch("image", "blur_horizontal", range, pyramid, cl_layout, horizontal, scratch_offset, cl_taps);
  launch("image", "blur_vertical", range, horizontal, cl_layout, blurred, scratch_offset, cl_taps);
}

}  // namespace porta::opencl
