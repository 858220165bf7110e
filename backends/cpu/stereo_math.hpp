// The integer arithmetic of stereo and projection matching (DESIGN.md §3.9, §3.10), kept apart
// from the kernels so that tests can pin each rounding rule on its own and other backends can
// copy it line for line. Internal to the cpu backend.
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "porta/keypoint.hpp"

namespace porta::cpu::stereo {

/// SAD refinement: windows of (2 * kSadHalfWindow + 1)^2 pixels, searched over
/// [-kSadSearch, kSadSearch] pixels around the right keypoint's column at the left level.
inline constexpr int kSadHalfWindow = 5;
inline constexpr int kSadSearch = 5;

/// Level-0 position in 1/256 px of coordinate `c` at a level of Q16 scale `scale_q16`:
/// (c * S + 128) >> 8, in uint32 as the contract says (it fits for images up to kMaxImageSide).
inline std::int32_t level0_q8(int c, std::int32_t scale_q16) {
  const std::uint32_t p = static_cast<std::uint32_t>(c) * static_cast<std::uint32_t>(scale_q16);
  return static_cast<std::int32_t>((p + 128u) >> 8);
}

/// Popcount of the XOR of two 256-bit descriptors, in [0, 256].
inline int hamming_distance(const Descriptor& a, const Descriptor& b) {
  int bits = 0;
  for (int w = 0; w < 4; ++w) {
    std::uint64_t x = 0, y = 0;
    std::memcpy(&x, a.bytes.data() + 8 * w, 8);
    std::memcpy(&y, b.bytes.data() + 8 * w, 8);
    bits += std::popcount(x ^ y);
  }
  return bits;
}

/// Q16 factor taking a column of the level whose scale is `source_q16` to the level whose scale is
/// `target_q16` (a column c there is at level 0 c * source, so at the target level
/// c * source / target): round(source * 65536 / target), as (source * 65536 + target / 2) / target.
/// Stereo calls it with (S[nR], S[nL]): right-keypoint column to the left keypoint's level.
inline std::int64_t level_ratio_q16(std::int32_t source_q16, std::int32_t target_q16) {
  return (static_cast<std::int64_t>(source_q16) * 65536 + target_q16 / 2) / target_q16;
}

/// A column multiplied by a Q16 ratio and rounded half up: (x * ratio + 2^15) >> 16.
inline std::int64_t scale_column(int x, std::int64_t ratio_q16) {
  return (static_cast<std::int64_t>(x) * ratio_q16 + 32768) >> 16;
}

/// Sub-pixel offset of a parabola's minimum through (-1, d1), (0, d2), (+1, d3), in 1/256 px,
/// rounded half away from zero. Requires d1 > d2 and d3 >= d2 (the SAD search's tie rule makes
/// this so at a best increment strictly inside the search range). Returns false (no match) when
/// the vertex lies more than one pixel away, which ORB-SLAM2 also rejects.
inline bool parabola_delta_q8(std::int32_t d1, std::int32_t d2, std::int32_t d3, std::int32_t& delta_q8) {
  const std::int64_t den = 2 * (static_cast<std::int64_t>(d1) + d3 - 2 * static_cast<std::int64_t>(d2));
  const std::int64_t diff = static_cast<std::int64_t>(d1) - d3;
  if (den <= 0) return false;  // unreachable under the precondition; keeps the division safe
  if ((diff < 0 ? -diff : diff) > den) return false;
  const std::int64_t num = diff * 256;
  const std::int64_t magnitude = ((num < 0 ? -num : num) * 2 + den) / (2 * den);
  delta_q8 = static_cast<std::int32_t>(num < 0 ? -magnitude : magnitude);
  return true;
}

/// A disparity at a level of scale `scale_q16`, in that level's 1/256 px, taken to level 0 and
/// rounded half up: (dn * S + 2^15) >> 16. `disparity_level_q8` must be >= 0.
inline std::int32_t level0_disparity_q8(std::int32_t disparity_level_q8, std::int32_t scale_q16) {
  return static_cast<std::int32_t>((static_cast<std::int64_t>(disparity_level_q8) * scale_q16 + 32768) >> 16);
}

/// The median of the contract: the element at index count / 2 of the values sorted ascending (the
/// upper median for an even count). `values` must not be empty.
inline std::int32_t median_sad(std::vector<std::int32_t> values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// ORB-SLAM2's outlier test on the SAD of an accepted match: sad > 1.5 * 1.4 * median, kept in
/// integers as sad * 10 > 21 * median.
inline bool sad_is_outlier(std::int32_t sad, std::int32_t median_sad) {
  return static_cast<std::int64_t>(sad) * 10 > static_cast<std::int64_t>(median_sad) * 21;
}

}  // namespace porta::cpu::stereo
