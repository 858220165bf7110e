// Keypoints, descriptors and match records exchanged with every backend. These are plain
// structs with a fixed byte layout (checked by static_assert) because they cross to devices.
#pragma once

#include <array>
#include <cstdint>

namespace porta {

/// A feature at its pyramid level. `response` 0 marks "no keypoint" in the dense cell array.
struct Keypoint {
  std::uint16_t x = 0;         ///< column at `level`
  std::uint16_t y = 0;         ///< row at `level`
  std::uint16_t response = 0;  ///< FAST score, sum of |I_i - c| over the circle
  std::uint8_t level = 0;
  std::uint8_t angle_bin = 0;  ///< orientation bin, see orientation_bin_center_rad()
};
static_assert(sizeof(Keypoint) == 8);

/// 256-bit rBRIEF descriptor; bit j is byte j/8, bit j%8 (least significant first).
struct Descriptor {
  std::array<std::uint8_t, 32> bytes{};
};
static_assert(sizeof(Descriptor) == 32);

/// Result of the stereo match for one left keypoint.
struct StereoMatch {
  std::int32_t disparity_q8 = -1;  ///< level-0 disparity in 1/256 px, -1 = no match
  std::int32_t right_index = -1;   ///< index into the right keypoint list, -1 = no match
};
static_assert(sizeof(StereoMatch) == 8);

/// A map point already projected into the frame, for projection matching (DESIGN.md §3.10).
struct ProjectionQuery {
  std::int32_t u_q8 = 0;         ///< level-0 column, 1/256 px
  std::int32_t v_q8 = 0;         ///< level-0 row, 1/256 px
  std::int32_t radius_q8 = 0;    ///< half-size of the square search window, 1/256 px
  std::uint8_t min_level = 0;    ///< keypoint levels accepted: [min_level, max_level]
  std::uint8_t max_level = 0;
  std::uint16_t reserved = 0;
};
static_assert(sizeof(ProjectionQuery) == 16);

/// Result of projection matching for one query: best and second-best Hamming distance.
struct ProjectionResult {
  std::int32_t best_index = -1;   ///< frame keypoint index, -1 = none in the window
  std::int32_t best_distance = 256;
  std::int32_t second_distance = 256;  ///< 256 when there was no second candidate
  std::int32_t reserved = 0;
};
static_assert(sizeof(ProjectionResult) == 16);

}  // namespace porta
