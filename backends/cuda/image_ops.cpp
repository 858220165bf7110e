// Image contracts of the CUDA backend (DESIGN.md §3.1, §3.2, §3.7): argument checks as the cpu
// backend's (backends/cpu/image_kernels.cpp), then the launches of image_kernels.cu.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "cuda/host_checks.hpp"

namespace porta::cuda {


// §3.1: one thread per destination pixel.
void CudaBackend::rectify(const Buffer& src, const Plane& src_plane, const Buffer& map, Buffer& dst,
                          const Plane& dst_plane) {
  checks::check_rectify(detail::kBackend, src, src_plane, map, dst, dst_plane, detail::kPlaneLimits);
  if (dst_plane.width <= 0 || dst_plane.height <= 0) return;
  activate();
  // An empty source reads 0 everywhere: the kernel's bounds tests see width or height 0.
  DevPlane sp = detail::to_dev(src_plane);
  if (src_plane.width <= 0 || src_plane.height <= 0) sp = DevPlane{0, 0, 0, 0, 0};
  enqueue<&launch_rectify>("rectify", dev<std::uint8_t>(src), sp, dev<std::int32_t>(map), dev<std::uint8_t>(dst),
                           detail::to_dev(dst_plane));
}

// §3.2: one launch per level, in order (each level reads the one above; the stream is in order).
void CudaBackend::build_pyramid(Buffer& pyramid, const PyramidLayout& layout, const Buffer& resize_table,
                                const std::vector<std::int32_t>& level_offset) {
  const int levels = layout.num_levels();
  checks::check_pyramid(detail::kBackend, pyramid, layout, resize_table, level_offset,
                        /*reject_negative_offsets=*/true, detail::kPlaneLimits);
  activate();
  for (int n = 1; n < levels; ++n) {
    const Plane& above = layout.levels[static_cast<std::size_t>(n - 1)];
    const Plane& level = layout.levels[static_cast<std::size_t>(n)];
    if (level.width <= 0 || level.height <= 0) continue;
    enqueue<&launch_resize_level>("build_pyramid", dev<std::uint8_t>(pyramid), detail::to_dev(above),
                                  detail::to_dev(level),
                                  dev<std::int32_t>(resize_table) + level_offset[static_cast<std::size_t>(n - 1)]);
  }
}

// §3.7: one launch over every level: a 32 x 8 tile per block, horizontal and vertical passes
// through shared memory.
void CudaBackend::blur(const Buffer& pyramid, const PyramidLayout& layout, Buffer& blurred,
                       const std::array<std::int32_t, 7>& taps) {
  checks::check_blur(detail::kBackend, pyramid, layout, blurred, taps, detail::kPlaneLimits);
  const DevTiledLevels tiles = detail::tile_levels(layout, "blur");
  if (tiles.first_block[tiles.count] == 0) return;
  activate();
  // In place (the same buffer twice): tiles would read pixels other tiles have already blurred,
  // so the source is copied first (the cpu reads a whole level before writing it).
  const Buffer* source = &pyramid;
  if (&pyramid == &blurred) {
    Buffer& copy = scratch("blur.source", pyramid.size_bytes());
    enqueue<&op_copy_d2d>("blur (in-place source copy)", dev<std::uint8_t>(copy),
                          static_cast<const std::uint8_t*>(dev<std::uint8_t>(pyramid)), pyramid.size_bytes());
    source = &copy;
  }
  DevBlurTaps t{};
  for (int k = 0; k < 7; ++k) t.t[k] = taps[static_cast<std::size_t>(k)];
  enqueue<&launch_blur>("blur", static_cast<const std::uint8_t*>(dev<std::uint8_t>(*source)),
                        dev<std::uint8_t>(blurred), tiles, t);
}

}  // namespace porta::cuda
