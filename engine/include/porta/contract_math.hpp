// The integer helpers of the kernel contracts (DESIGN.md §3, docs/ARCHITECTURE.md), written once
// for host and device: plain C++17 with no library beyond <cstdint>, every function
// `__host__ __device__` under nvcc, so that the cpu reference (backends/cpu/stereo_math.hpp
// forwards here) and the CUDA kernels share one definition of each rounding rule. OpenCL and GLSL
// sources cannot include C++: they restate these lines, and the equivalence suite holds them equal.
#pragma once

#include <cstdint>

#if defined(__CUDACC__)
#define PORTA_HD __host__ __device__ __forceinline__
#else
#define PORTA_HD inline
#endif

namespace porta::contract {

/// SAD refinement of stereo matching (§3.9): (2 * kSadHalfWindow + 1)^2 windows searched over
/// [-kSadSearch, kSadSearch] around the right keypoint's column at the left level.
inline constexpr int kSadHalfWindow = 5;
inline constexpr int kSadSearch = 5;
inline constexpr int kSadSlots = 2 * kSadSearch + 1;
/// The largest centred 11 x 11 SAD: 120 non-centre pixels of |diff| <= 510.
inline constexpr int kMaxCentredSad = 120 * 510;

/// Reflect-101 index into [0, n): -1 -> 1, n -> n-2, repeated as needed; 0 when n == 1
/// (tables.hpp reflect101, §3.7).
PORTA_HD int reflect101(int i, int n) {
  if (n == 1) return 0;
  const int period = 2 * n - 2;
  i = i < 0 ? -i : i;
  i %= period;
  return i < n ? i : period - i;
}

/// Level-0 position in 1/256 px of coordinate `c` at a level of Q16 scale `scale_q16`:
/// (c * S + 128) >> 8 in uint32 (§3.9, §3.10).
PORTA_HD std::int32_t level0_q8(int c, std::int32_t scale_q16) {
  const std::uint32_t p = static_cast<std::uint32_t>(c) * static_cast<std::uint32_t>(scale_q16);
  return static_cast<std::int32_t>((p + 128u) >> 8);
}

/// PFA's level-0 pixel of a level coordinate (§3.5): (c * S) >> 16 in 64 bits, clamped to
/// `limit` (the level-0 side - 1). The scale is sign-extended first, as the cpu backend does.
PORTA_HD std::uint64_t pfa_level0(int c, std::int32_t scale_q16, int limit) {
  const std::uint64_t p =
      (static_cast<std::uint64_t>(c) * static_cast<std::uint64_t>(static_cast<std::int64_t>(scale_q16))) >>
      16;
  const std::uint64_t l = static_cast<std::uint64_t>(limit);
  return p < l ? p : l;
}

/// Q16 factor taking a column of the level whose scale is `source_q16` to the level whose scale is
/// `target_q16` (column c is at level 0 c * source, so at the target level c * source / target):
/// (source * 65536 + target / 2) / target. Stereo calls it with (S[nR], S[nL]) (§3.9).
PORTA_HD std::int64_t level_ratio_q16(std::int32_t source_q16, std::int32_t target_q16) {
  return (static_cast<std::int64_t>(source_q16) * 65536 + target_q16 / 2) / target_q16;
}

/// A column multiplied by a Q16 ratio and rounded half up: (x * ratio + 2^15) >> 16.
PORTA_HD std::int64_t scale_column(int x, std::int64_t ratio_q16) {
  return (static_cast<std::int64_t>(x) * ratio_q16 + 32768) >> 16;
}

/// Sub-pixel offset of a parabola's minimum through (-1, d1), (0, d2), (+1, d3), in 1/256 px,
/// rounded half away from zero; false (no match) when den <= 0 or |d1 - d3| > den.
PORTA_HD bool parabola_delta_q8(std::int32_t d1, std::int32_t d2, std::int32_t d3, std::int32_t& delta_q8) {
  const std::int64_t den = 2 * (static_cast<std::int64_t>(d1) + d3 - 2 * static_cast<std::int64_t>(d2));
  const std::int64_t diff = static_cast<std::int64_t>(d1) - d3;
  if (den <= 0) return false;
  if ((diff < 0 ? -diff : diff) > den) return false;
  const std::int64_t num = diff * 256;
  const std::int64_t magnitude = ((num < 0 ? -num : num) * 2 + den) / (2 * den);
  delta_q8 = static_cast<std::int32_t>(num < 0 ? -magnitude : magnitude);
  return true;
}

/// A disparity at a level of scale `scale_q16`, in that level's 1/256 px, taken to level 0 and
/// rounded half up in 64 bits: (dn * S + 2^15) >> 16.
PORTA_HD std::int32_t level0_disparity_q8(std::int32_t disparity_level_q8, std::int32_t scale_q16) {
  return static_cast<std::int32_t>((static_cast<std::int64_t>(disparity_level_q8) * scale_q16 + 32768) >> 16);
}

/// ORB-SLAM2's outlier test: sad > 2.1 * median, as sad * 10 > 21 * median in 64 bits.
PORTA_HD bool sad_is_outlier(std::int32_t sad, std::int32_t median_sad) {
  return static_cast<std::int64_t>(sad) * 10 > static_cast<std::int64_t>(median_sad) * 21;
}

/// Orientation (§3.6): cross(u, m) = u.x * m01 - u.y * m10 (|u| <= 1024, |m| < 2^20: int32).
PORTA_HD std::int32_t orientation_cross(std::int32_t ux, std::int32_t uy, std::int32_t m10,
                                        std::int32_t m01) {
  return ux * m01 - uy * m10;
}

}  // namespace porta::contract
