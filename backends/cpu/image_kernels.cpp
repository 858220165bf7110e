// Image kernels of the cpu backend: rectification, pyramid construction and the descriptor blur
// (DESIGN.md §3.1, §3.2, §3.7). Integer arithmetic only; each parallel index writes its own
// output row, so the bytes never depend on the thread count.
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "porta/kernel_checks.hpp"
#include "porta/tables.hpp"

namespace porta::cpu {

namespace {

constexpr const char* kBackend = "cpu";

}  // namespace

// §3.1: dst(x, y) = bilinear sample of `src` at the Q5 map position (xq, yq) of that pixel:
// 5-bit weights whose products sum to 1024, (sum w * p + 512) >> 10, taps outside `src` read 0.
// x0 = xq >> 5 is a floor also for negative xq (C++20 defines >> on negatives as arithmetic).
void CpuBackend::rectify(const Buffer& src, const Plane& src_plane, const Buffer& map, Buffer& dst,
                         const Plane& dst_plane) {
  checks::check_rectify(kBackend, src, src_plane, map, dst, dst_plane);
  if (dst_plane.width <= 0 || dst_plane.height <= 0) return;

  const std::uint8_t* src_pixels = as<std::uint8_t>(src, src_plane.offset_bytes);
  const std::int32_t* map_q5 = as<std::int32_t>(map);
  std::uint8_t* dst_pixels = as<std::uint8_t>(dst, dst_plane.offset_bytes);
  const int src_w = src_plane.width, src_h = src_plane.height, src_pitch = src_plane.pitch;

  auto tap = [&](int x, int y) -> std::uint32_t {
    if (x < 0 || y < 0 || x >= src_w || y >= src_h) return 0;
    return src_pixels[static_cast<std::int64_t>(y) * src_pitch + x];
  };

  pool().parallel_for(0, dst_plane.height, [&](std::int64_t y) {
    const std::int32_t* row_map = map_q5 + y * dst_plane.width * 2;
    std::uint8_t* out = dst_pixels + y * dst_plane.pitch;
    for (int x = 0; x < dst_plane.width; ++x) {
      const std::int32_t xq = row_map[2 * x], yq = row_map[2 * x + 1];
      const int x0 = xq >> 5, y0 = yq >> 5;
      const std::uint32_t fx = static_cast<std::uint32_t>(xq & 31), fy = static_cast<std::uint32_t>(yq & 31);
      const std::uint32_t sum = (32 - fx) * (32 - fy) * tap(x0, y0) + fx * (32 - fy) * tap(x0 + 1, y0) +
                                (32 - fx) * fy * tap(x0, y0 + 1) + fx * fy * tap(x0 + 1, y0 + 1);
      out[x] = static_cast<std::uint8_t>((sum + 512) >> 10);
    }
  });
}

// §3.2: level n (n >= 1) from level n-1 with the host-built resize table (ResizeTables::packed):
// out = (wy0 * (wx0 * p00 + wx1 * p10) + wy1 * (wx0 * p01 + wx1 * p11) + 2^21) >> 22 with 11-bit
// weights. Levels run in order (each reads the one above); rows of a level run in parallel.
void CpuBackend::build_pyramid(Buffer& pyramid, const PyramidLayout& layout, const Buffer& resize_table,
                               const std::vector<std::int32_t>& level_offset) {
  const int levels = layout.num_levels();
  checks::check_pyramid(kBackend, pyramid, layout, resize_table, level_offset,
                        /*reject_negative_offsets=*/false);

  const std::int32_t* table = as<std::int32_t>(resize_table);
  for (int n = 1; n < levels; ++n) {
    const Plane& above = layout.levels[n - 1];
    const Plane& level = layout.levels[n];
    const std::int32_t* col_src0 = table + level_offset[n - 1];
    const std::int32_t* col_w1 = col_src0 + level.width;
    const std::int32_t* row_src0 = col_w1 + level.width;
    const std::int32_t* row_w1 = row_src0 + level.height;
    const std::uint8_t* src = as<std::uint8_t>(pyramid, above.offset_bytes);
    std::uint8_t* dst = as<std::uint8_t>(pyramid, level.offset_bytes);

    pool().parallel_for(0, level.height, [&](std::int64_t i) {
      const int y0 = row_src0[i];
      const int y1 = std::min(y0 + 1, above.height - 1);
      const std::uint32_t wy1 = static_cast<std::uint32_t>(row_w1[i]), wy0 = 2048 - wy1;
      const std::uint8_t* top = src + static_cast<std::int64_t>(y0) * above.pitch;
      const std::uint8_t* bottom = src + static_cast<std::int64_t>(y1) * above.pitch;
      std::uint8_t* out = dst + i * level.pitch;
      for (int j = 0; j < level.width; ++j) {
        const int x0 = col_src0[j];
        const int x1 = std::min(x0 + 1, above.width - 1);
        const std::uint32_t wx1 = static_cast<std::uint32_t>(col_w1[j]), wx0 = 2048 - wx1;
        // At most 2048 * (2048 * 255) + 2^21 < 2^31: no overflow in 32 bits.
        const std::uint32_t sum =
            wy0 * (wx0 * top[x0] + wx1 * top[x1]) + wy1 * (wx0 * bottom[x0] + wx1 * bottom[x1]);
        out[j] = static_cast<std::uint8_t>((sum + (1u << 21)) >> 22);
      }
    });
  }
}

// §3.7: separable 7-tap blur of every level with reflect-101 borders. The horizontal pass keeps
// h = sum t_k * p unrounded (uint16: at most 255 * 256); the vertical pass gives
// (sum t_k * h + 2^15) >> 16. Taps must be non-negative and sum to 256 (build_blur_taps()).
void CpuBackend::blur(const Buffer& pyramid, const PyramidLayout& layout, Buffer& blurred,
                      const std::array<std::int32_t, 7>& taps) {
  checks::check_blur(kBackend, pyramid, layout, blurred, taps);

  std::vector<std::uint16_t> horizontal;  // one level's horizontal pass, packed (pitch = width)
  std::vector<int> reflected_x;           // reflected_x[x + 3] = reflect101(x, width), x in [-3, width + 3)
  for (const Plane& level : layout.levels) {
    const int width = level.width, height = level.height;
    if (width <= 0 || height <= 0) continue;
    const std::uint8_t* src = as<std::uint8_t>(pyramid, level.offset_bytes);
    std::uint8_t* dst = as<std::uint8_t>(blurred, level.offset_bytes);

    reflected_x.resize(static_cast<std::size_t>(width) + 6);
    for (int x = -3; x < width + 3; ++x) reflected_x[static_cast<std::size_t>(x + 3)] = reflect101(x, width);
    horizontal.resize(static_cast<std::size_t>(width) * height);  // every element is written below

    pool().parallel_for(0, height, [&](std::int64_t y) {
      const std::uint8_t* row = src + y * level.pitch;
      std::uint16_t* h = horizontal.data() + y * width;
      for (int x = 0; x < width; ++x) {
        const int* cols = reflected_x.data() + x;  // cols[k] = reflect101(x + k - 3)
        std::uint32_t sum = 0;
        for (int k = 0; k < 7; ++k) sum += static_cast<std::uint32_t>(taps[k]) * row[cols[k]];
        h[x] = static_cast<std::uint16_t>(sum);
      }
    });

    pool().parallel_for(0, height, [&](std::int64_t y) {
      std::array<const std::uint16_t*, 7> rows{};
      for (int k = 0; k < 7; ++k)
        rows[k] = horizontal.data() +
                  static_cast<std::int64_t>(reflect101(static_cast<int>(y) + k - 3, height)) * width;
      std::uint8_t* out = dst + y * level.pitch;
      for (int x = 0; x < width; ++x) {
        std::uint32_t sum = 0;  // at most 256 * 65280 + 2^15 < 2^24
        for (int k = 0; k < 7; ++k) sum += static_cast<std::uint32_t>(taps[k]) * rows[k][x];
        out[x] = static_cast<std::uint8_t>((sum + (1u << 15)) >> 16);
      }
    });
  }
}

}  // namespace porta::cpu
