// The integer arithmetic of stereo and projection matching (DESIGN.md §3.9, §3.10), kept apart
// from the kernels so that tests can pin each rounding rule on its own. The rules themselves live
// in common/contract_math.hpp, shared with the CUDA kernels (engine/include/porta). Internal to the cpu backend.
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "porta/contract_math.hpp"
#include "porta/keypoint.hpp"

namespace porta::cpu::stereo {

// The rounding rules shared with the device backends (one definition, in porta/contract_math.hpp).
using contract::kSadHalfWindow;
using contract::kSadSearch;
using contract::level0_disparity_q8;
using contract::level0_q8;
using contract::level_ratio_q16;
using contract::parabola_delta_q8;
using contract::sad_is_outlier;
using contract::scale_column;

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

/// The median of the contract: the element at index count / 2 of the values sorted ascending (the
/// upper median for an even count). `values` must not be empty.
inline std::int32_t median_sad(std::vector<std::int32_t> values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace porta::cpu::stereo
