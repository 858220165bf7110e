// Image kernels of the cpu backend: rectification, pyramid construction and the descriptor blur
// (DESIGN.md §3.1, §3.2, §3.7). Integer arithmetic only; each parallel index writes its own
// output row, so the bytes never depend on the thread count.
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "cpu/simd.hpp"  // PORTA_CPU_HOT
#include "porta/kernel_checks.hpp"
#include "porta/tables.hpp"

namespace porta::cpu {

namespace {

constexpr const char* kBackend = "cpu";

/// A per-thread scratch array of at least `count` elements, kept between calls so that the hot
/// loops do not allocate (it only grows, e.g. on the first frame).
template <typename T>
T* scratch(int count) {
  thread_local std::vector<T> buffer;
  if (buffer.size() < static_cast<std::size_t>(count)) buffer.resize(static_cast<std::size_t>(count));
  return buffer.data();
}

// ---- Pyramid row (§3.2) --------------------------------------------------------------------------

/// One output row of a pyramid level from its two source rows `top` and `bottom` (of `src_width`
/// pixels) and the row weights wy0 + wy1 = 2048; `blend` has room for `src_width` + 1 values.
///
/// The contract's sum wy0 * (wx0 * a + wx1 * b) + wy1 * (wx0 * c + wx1 * d) (a, b from `top` at
/// x0, x1; c, d from `bottom`) equals wx0 * (wy0 * a + wy1 * c) + wx1 * (wy0 * b + wy1 * d) in exact
/// integer arithmetic, and nothing overflows uint32: blend[x] = wy0 * top[x] + wy1 * bottom[x]
/// <= 2048 * 255 = 522 240 (< 2^19), and wx0 * blend[x0] + wx1 * blend[x1] + 2^21
/// <= 2048 * 522 240 + 2^21 = 255 * 2^22 + 2^21 < 2^30. So the vertical blend runs over whole rows
/// in vectors, and only the horizontal step gathers through the column table.
PORTA_CPU_HOT void pyramid_row(const std::uint8_t* __restrict top, const std::uint8_t* __restrict bottom,
                               int src_width, std::uint32_t wy0, std::uint32_t wy1,
                               const std::int32_t* __restrict col_src0, const std::int32_t* __restrict col_w1,
                               int width, std::uint32_t* __restrict blend, std::uint8_t* __restrict out) {
  // Vertical blend of the whole row (GCC vectorises this loop: 8 uint32 lanes in the AVX2 clone).
  for (int x = 0; x < src_width; ++x) blend[x] = wy0 * top[x] + wy1 * bottom[x];
  // The right neighbour of the last column is the last column (x1 = min(x0 + 1, width - 1)):
  // one padding entry replaces the clamp in the loop below. `blend` has src_width + 1 entries.
  blend[src_width] = blend[src_width - 1];

  // Horizontal step: a gather through the column table. The pointers are __restrict (the output
  // aliases none of the tables), so GCC vectorises it too: 1242 -> 1035 columns in 980 ns instead of
  // 1 218 (SSE2) and 702 instead of 1 250 (AVX2) on the 2-core machine.
  for (int j = 0; j < width; ++j) {
    const auto x0 = static_cast<std::size_t>(col_src0[j]);
    const auto wx1 = static_cast<std::uint32_t>(col_w1[j]), wx0 = 2048 - wx1;
    out[j] = static_cast<std::uint8_t>((wx0 * blend[x0] + wx1 * blend[x0 + 1] + (1u << 21)) >> 22);
  }
}

// ---- Blur row (§3.7) -----------------------------------------------------------------------------

/// The seven taps, and the seven source rows of one output row (struct, not arrays, to pass them
/// by reference to the hot function).
struct BlurTaps {
  std::array<std::uint16_t, 7> v;
};
struct BlurRows {
  std::array<const std::uint8_t*, 7> r;
};

/// One output row of the blur from its source rows `rows.r[k]` (= row reflect101(y + k - 3)).
/// `padded` has room for width + 6 values: padded[x + 3] holds the vertical pass at column x, and
/// the three entries on each side its reflect-101 continuation, so the horizontal pass needs no
/// border case.
///
/// Both passes are plain loops over x with the taps unrolled that GCC vectorises at -O3 (checked
/// with -fopt-info-vec: 16 uint16 lanes for the vertical pass and 8 uint32 lanes for the
/// horizontal one in the AVX2 clone, half that in the SSE2 baseline and on NEON); what keeps them
/// vectorisable is that no index goes through a table. The row pointers and taps are copied to
/// locals so that the stores cannot be taken to modify them.
PORTA_CPU_HOT void blur_row(const BlurRows& rows, int width, const BlurTaps& taps, std::uint16_t* padded,
                            std::uint8_t* out) {
  const std::array<const std::uint8_t*, 7> r = rows.r;
  const std::array<std::uint16_t, 7> t = taps.v;
  // A Gaussian's taps are symmetric (t_k = t_{6-k}, build_blur_taps()): then each pass adds the
  // mirrored pixels first and multiplies four times instead of seven. The sum is the same integer
  // (every term is non-negative and the total fits, so no partial sum wraps).
  const bool symmetric = t[0] == t[6] && t[1] == t[5] && t[2] == t[4];

  // Vertical pass: padded[x + 3] = sum_k t_k * r[k][x], exact in uint16 since the taps sum to 256:
  // at most 256 * 255 = 65 280.
  if (symmetric) {
    const std::uint16_t t0 = t[0], t1 = t[1], t2 = t[2], t3 = t[3];
    for (int x = 0; x < width; ++x) {
      const auto s0 = static_cast<std::uint16_t>(r[0][x] + r[6][x]);
      const auto s1 = static_cast<std::uint16_t>(r[1][x] + r[5][x]);
      const auto s2 = static_cast<std::uint16_t>(r[2][x] + r[4][x]);
      padded[x + 3] = static_cast<std::uint16_t>(t0 * s0 + t1 * s1 + t2 * s2 + t3 * r[3][x]);
    }
  } else {
    for (int x = 0; x < width; ++x) {
      std::uint16_t sum = 0;
      for (int k = 0; k < 7; ++k) sum = static_cast<std::uint16_t>(sum + t[k] * r[k][x]);
      padded[x + 3] = sum;
    }
  }

  // Borders: columns -3..-1 and width..width+2 mirror the row (reflect-101, also for widths < 4,
  // where the mirrored columns repeat).
  for (int k = 1; k <= 3; ++k) {
    padded[3 - k] = padded[3 + reflect101(-k, width)];
    padded[width + 2 + k] = padded[3 + reflect101(width - 1 + k, width)];
  }

  // Horizontal pass: out[x] = (sum_k t_k * padded[x + k] + 2^15) >> 16, in uint32: at most
  // 256 * 65 280 + 2^15 < 2^24, and the quotient fits a byte.
  const std::array<std::uint32_t, 7> t32 = {t[0], t[1], t[2], t[3], t[4], t[5], t[6]};
  if (symmetric) {
    const std::uint32_t t0 = t32[0], t1 = t32[1], t2 = t32[2], t3 = t32[3];
    for (int x = 0; x < width; ++x) {
      const std::uint32_t s0 = std::uint32_t{padded[x]} + padded[x + 6];
      const std::uint32_t s1 = std::uint32_t{padded[x + 1]} + padded[x + 5];
      const std::uint32_t s2 = std::uint32_t{padded[x + 2]} + padded[x + 4];
      const std::uint32_t sum = t0 * s0 + t1 * s1 + t2 * s2 + t3 * padded[x + 3];
      out[x] = static_cast<std::uint8_t>((sum + (1u << 15)) >> 16);
    }
    return;
  }
  for (int x = 0; x < width; ++x) {
    std::uint32_t sum = 0;
    for (int k = 0; k < 7; ++k) sum += t32[k] * padded[x + k];
    out[x] = static_cast<std::uint8_t>((sum + (1u << 15)) >> 16);
  }
}

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
// Computed as wx0 * b[x0] + wx1 * b[x1] with the vertical blend b = wy0 * top + wy1 * bottom of
// the two source rows (see pyramid_row): the same exact integer sum, regrouped.
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
      const auto wy1 = static_cast<std::uint32_t>(row_w1[i]);
      std::uint32_t* blend = scratch<std::uint32_t>(above.width + 1);
      pyramid_row(src + static_cast<std::int64_t>(y0) * above.pitch,
                  src + static_cast<std::int64_t>(y1) * above.pitch, above.width, 2048 - wy1, wy1, col_src0,
                  col_w1, level.width, blend, dst + i * level.pitch);
    });
  }
}

// §3.7: separable 7-tap blur of every level with reflect-101 borders:
// out = (sum_ky t_ky * sum_kx t_kx * p(x + kx - 3, y + ky - 3) + 2^15) >> 16, computed exactly (no
// rounding between the passes). Taps must be non-negative and sum to 256 (build_blur_taps()).
// Because the double sum is exact, the passes may run in either order: each output row is the
// vertical pass of its 7 source rows into a scratch row, then the horizontal pass (blur_row).
void CpuBackend::blur(const Buffer& pyramid, const PyramidLayout& layout, Buffer& blurred,
                      const std::array<std::int32_t, 7>& taps) {
  checks::check_blur(kBackend, pyramid, layout, blurred, taps);

  BlurTaps t;  // checked above: each tap in [0, 256]
  for (int k = 0; k < 7; ++k) t.v[k] = static_cast<std::uint16_t>(taps[k]);
  for (const Plane& level : layout.levels) {
    const int width = level.width, height = level.height;
    if (width <= 0 || height <= 0) continue;
    const std::uint8_t* src = as<std::uint8_t>(pyramid, level.offset_bytes);
    std::uint8_t* dst = as<std::uint8_t>(blurred, level.offset_bytes);

    pool().parallel_for(0, height, [&](std::int64_t y) {
      BlurRows rows;  // rows.r[k] = source row reflect101(y + k - 3)
      for (int k = 0; k < 7; ++k)
        rows.r[k] =
            src + static_cast<std::int64_t>(reflect101(static_cast<int>(y) + k - 3, height)) * level.pitch;
      blur_row(rows, width, t, scratch<std::uint16_t>(width + 6), dst + y * level.pitch);
    });
  }
}

}  // namespace porta::cpu
