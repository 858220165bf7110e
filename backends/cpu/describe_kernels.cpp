// Orientation and ORB descriptor kernels of the cpu backend: the reference for DESIGN.md §3.6
// and §3.8. One keypoint per parallel_for index; each writes only its own record or descriptor.
#include <array>
#include <cstdint>
#include <string>

#include "cpu/cpu_backend.hpp"
#include "cpu/simd.hpp"
#include "porta/kernel_checks.hpp"
#include "porta/tables.hpp"

namespace porta::cpu {

namespace {

/// How far the rotated ORB pattern reaches from the keypoint (tables.hpp: within [-18, 18]).
constexpr int kOrbPatternReach = 18;

constexpr const char* kBackend = "cpu";

[[noreturn]] void fail(const char* call, const std::string& what) { checks::fail(kBackend, call, what); }

/// Checks what the kernels index with before any thread starts, so that a bad argument is an
/// error naming the keypoint instead of a read outside the buffer.
void check_keypoints(const char* call, const Keypoint* keypoints, int count, const PyramidLayout& layout,
                     int reach, int bins) {
  checks::check_8bit_pixels(kBackend, call, layout);
  for (int i = 0; i < count; ++i) {
    const Keypoint& kp = keypoints[i];
    // Named only when one fails (this runs over every keypoint of every frame).
    const auto which_one = [&] {
      return "keypoint " + std::to_string(i) + " (" + std::to_string(kp.x) + ", " + std::to_string(kp.y) +
             ", level " + std::to_string(kp.level) + ")";
    };
    if (kp.level >= layout.num_levels())
      fail(call,
           which_one() + " names a level outside the " + std::to_string(layout.num_levels()) + "-level pyramid");
    const Plane& plane = layout.levels[kp.level];
    if (kp.x < reach || kp.y < reach || kp.x + reach >= plane.width || kp.y + reach >= plane.height)
      fail(call, which_one() + " is closer than " + std::to_string(reach) + " px to the border of its " +
                     std::to_string(plane.width) + "x" + std::to_string(plane.height) + " level");
    if (bins > 0 && kp.angle_bin >= bins)
      fail(call, which_one() + " has angle bin " + std::to_string(kp.angle_bin) + " outside [0, " +
                     std::to_string(bins) + ")");
  }
}

/// cross(u, m) = u.x * m.y - u.y * m.x. |u| <= 1024 and |m| < 2^20 keep it inside int32.
std::int32_t cross(const std::int32_t* u, std::int32_t m10, std::int32_t m01) {
  return u[0] * m01 - u[1] * m10;
}

using simd::convert;
using simd::load;
using simd::u16x16;
using simd::u8x16;

/// The moments m10 = sum dx * I and m01 = sum dy * I over the disc |dy| <= 15, |dx| <= umax[|dy|]
/// around `centre`, each row's 31 columns in two 16-lane halves: lanes 0..15 of the left half hold
/// dx = -15..0, lanes 0..15 of the right half dx = 0..15 (its lane 0, the centre column, is masked
/// off: the left half counts it). The loads stay inside [-15, 15], which check_keypoints() and
/// check_orient_tables() (umax in [0, 15]) guarantee to be inside the level. Per lane, over the
/// 31 rows:
///   column[dx]   = sum_dy I          <= 31 * 255 = 7 905, exact in uint16;
///   weighted[dx] = sum_dy dy * I     |.| <= 255 * (1 + ... + 15) = 30 600, exact in int16 (the
///                                     uint16 lanes wrap, and the final value fits);
/// then m10 = sum_dx dx * column[dx] and m01 = sum_dx weighted[dx] in int32.
PORTA_CPU_HOT void disc_moments(const std::uint8_t* centre, std::int64_t pitch,
                                const std::array<int, 16>& umax, std::int32_t* m10_out,
                                std::int32_t* m01_out) {
  const u16x16 lane = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
  u16x16 column_left = {}, column_right = {}, weighted_left = {}, weighted_right = {};
  for (int dy = -kOrientationRadius; dy <= kOrientationRadius; ++dy) {
    const std::uint8_t* row = centre + dy * pitch;
    const auto half_width = static_cast<std::uint16_t>(umax[dy < 0 ? -dy : dy]);
    // Inside the disc: left lane l (dx = l - 15) when l >= 15 - half_width; right lane l (dx = l)
    // when 1 <= l <= half_width. Comparisons give all-ones (-1) lanes, so they serve as masks.
    const u16x16 in_left = (u16x16)(lane >= static_cast<std::uint16_t>(15 - half_width));
    const u16x16 in_right = (u16x16)((lane >= 1) & (lane <= half_width));
    const u16x16 left = convert<u16x16>(load<u8x16>(row - kOrientationRadius)) & in_left;
    const u16x16 right = convert<u16x16>(load<u8x16>(row)) & in_right;
    const auto dy16 = static_cast<std::uint16_t>(dy);  // dy modulo 2^16
    column_left += left;
    column_right += right;
    weighted_left += left * dy16;
    weighted_right += right * dy16;
  }
  std::int32_t m10 = 0, m01 = 0;
  for (int l = 0; l < 16; ++l) {
    m10 += (l - kOrientationRadius) * static_cast<std::int32_t>(column_left[l]) +
           l * static_cast<std::int32_t>(column_right[l]);
    m01 += static_cast<std::int16_t>(weighted_left[l]) + static_cast<std::int16_t>(weighted_right[l]);
  }
  *m10_out = m10;
  *m01_out = m01;
}

}  // namespace

// §3.6: angle_bin of each listed keypoint from the moments m10 = sum dx * I, m01 = sum dy * I over
// the disc |dy| <= 15, |dx| <= umax[|dy|] of its unblurred level; the bin is the first b with
// cross(u_b, m) >= 0 > cross(u_{b+1 mod B}, m), bin 0 when none (m = 0). Other fields unchanged.
void CpuBackend::orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
                        const std::array<int, 16>& umax, const Buffer& boundaries, int bins) {
  checks::check_orient_tables(kBackend, umax, boundaries, bins);
  const int count = list_count(keypoints);
  Keypoint* records = as<Keypoint>(*keypoints.items);
  check_keypoints("orient", records, count, layout, kOrientationRadius, 0);
  const std::int32_t* u = as<std::int32_t>(boundaries);

  pool().parallel_for(0, count, [&](std::int64_t i) {
    Keypoint& kp = records[i];
    const Plane& plane = layout.levels[kp.level];
    const std::uint8_t* centre =
        as<std::uint8_t>(pyramid, plane.offset_bytes) + static_cast<std::int64_t>(kp.y) * plane.pitch + kp.x;
    // |m| <= 255 * sum over the half disc of |dx| < 2^20, so int32 holds both moments.
    std::int32_t m10 = 0, m01 = 0;
    disc_moments(centre, plane.pitch, umax, &m10, &m01);
    int bin = 0;
    for (int b = 0; b < bins; ++b) {
      const int next = b + 1 == bins ? 0 : b + 1;
      if (cross(u + 2 * b, m10, m01) >= 0 && cross(u + 2 * next, m10, m01) < 0) {
        bin = b;
        break;
      }
    }
    kp.angle_bin = static_cast<std::uint8_t>(bin);
  });
}

// §3.8: descriptor i of keypoint i from its blurred level: bit j = I(p + a_j) < I(p + b_j) with
// (a_j, b_j) the j-th pair of the pattern of its angle bin, stored in byte j / 8 at bit j % 8.
void CpuBackend::orb_describe(const Buffer& blurred, const PyramidLayout& layout, ConstDeviceList keypoints,
                              const Buffer& pattern, Buffer& descriptors) {
  constexpr std::size_t kBinBytes = static_cast<std::size_t>(kOrbPairs) * 4;
  const int bins = checks::orb_pattern_bins(kBackend, pattern);
  const int count = list_count(keypoints);
  const Keypoint* records = as<Keypoint>(*keypoints.items);
  check_keypoints("orb_describe", records, count, layout, kOrbPatternReach, bins);
  if (descriptors.size_bytes() < static_cast<std::size_t>(count) * sizeof(Descriptor))
    fail("orb_describe", "the descriptor buffer holds fewer than " + std::to_string(count) + " descriptors");
  const std::int8_t* table = as<std::int8_t>(pattern);
  Descriptor* out = as<Descriptor>(descriptors);

  pool().parallel_for(0, count, [&](std::int64_t i) {
    const Keypoint& kp = records[i];
    const Plane& plane = layout.levels[kp.level];
    const std::uint8_t* centre =
        as<std::uint8_t>(blurred, plane.offset_bytes) + static_cast<std::int64_t>(kp.y) * plane.pitch + kp.x;
    const std::int8_t* pairs = table + kp.angle_bin * kBinBytes;
    Descriptor d;
    for (int byte = 0; byte < 32; ++byte) {
      std::uint32_t bits = 0;
      for (int bit = 0; bit < 8; ++bit) {
        const std::int8_t* p = pairs + (byte * 8 + bit) * 4;
        const std::uint8_t a = centre[static_cast<std::int64_t>(p[1]) * plane.pitch + p[0]];
        const std::uint8_t b = centre[static_cast<std::int64_t>(p[3]) * plane.pitch + p[2]];
        bits |= static_cast<std::uint32_t>(a < b) << bit;
      }
      d.bytes[byte] = static_cast<std::uint8_t>(bits);
    }
    out[i] = d;
  });
}

}  // namespace porta::cpu
