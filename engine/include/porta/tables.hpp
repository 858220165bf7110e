// Host-side table builders shared by all backends (DESIGN.md §3): every table is computed once,
// here, in double precision and rounded to integers, so that no two backends compute it twice.
#pragma once

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "porta/contract_math.hpp"
#include "porta/layout.hpp"
#include "porta/settings.hpp"

namespace porta {

// ---- FAST (§3.3) -------------------------------------------------------------------------------

/// The 16 offsets (dx, dy) of the radius-3 Bresenham circle, in circular order.
extern const std::array<std::pair<int, int>, 16> kFastCircle;

/// Longest run of ones in a 16-bit mask read circularly (0 for 0, 16 for 0xFFFF).
int longest_circular_run(std::uint16_t mask);

/// 65 536 bytes: entry m is 1 when longest_circular_run(m) lies in [min_arc, max_arc], else 0.
std::vector<std::uint8_t> build_fast_lut(int min_arc, int max_arc);

// ---- Pyramid (§3.2) ----------------------------------------------------------------------------

/// Level sizes: level n is max(1, round(W / s^n)) x max(1, round(H / s^n)).
std::vector<std::pair<int, int>> pyramid_level_sizes(int width, int height, int levels, double scale);

/// Bilinear resize indices and 11-bit weights from level n-1 to level n, for n >= 1.
/// For destination column j: source x = (j + 0.5) * W_{n-1} / W_n - 0.5 clamped to [0, W_{n-1}-1],
/// x0 = floor(x), w1 = round((x - x0) * 2048), w0 = 2048 - w1, x1 = min(x0 + 1, W_{n-1} - 1).
/// Rows likewise. A destination pixel is (sum_{a,b} wy_a * wx_b * p(y_a, x_b) + 2^21) >> 22.
struct ResizeAxis {
  std::vector<std::int32_t> src0;  ///< x0 (or y0) per destination column (or row)
  std::vector<std::int32_t> w1;    ///< weight of src0 + 1, in [0, 2048]; src0 gets 2048 - w1
};
struct ResizeTables {
  std::vector<ResizeAxis> cols;  ///< index n-1 for level n
  std::vector<ResizeAxis> rows;
  /// The same data packed into one int32 array for upload: per level n >= 1, in order:
  /// cols.src0 (W_n), cols.w1 (W_n), rows.src0 (H_n), rows.w1 (H_n). `level_offset[n-1]` is the
  /// index of level n's first int.
  std::vector<std::int32_t> packed;
  std::vector<std::int32_t> level_offset;
};
ResizeTables build_resize_tables(const std::vector<std::pair<int, int>>& level_sizes);

/// Q16 scale of level n relative to level 0: S[n] = round(s^n * 65536). Level-0 position of a
/// level-n pixel x is (x * S[n]) >> 16 (PFA) or, in 1/256 px, (x * S[n] + 128) >> 8.
std::vector<std::int32_t> build_level_scales_q16(int levels, double scale);

// ---- Culling (§3.4) ----------------------------------------------------------------------------

/// Cell size of level n: max(1, floor(c0 / s^n)) per axis; grid tiled from (0,0).
CellLayout build_cell_layout(const std::vector<std::pair<int, int>>& level_sizes, int cell_width,
                             int cell_height, double scale);

// ---- Orientation (§3.6) ------------------------------------------------------------------------

inline constexpr int kOrientationRadius = 15;
/// umax[dy] for dy in [0, 15]: the patch holds (dx, dy) with |dx| <= umax[|dy|]; it is the disc
/// dx^2 + dy^2 <= 240 (radius 15.5 rounded down in the squared distance).
std::array<int, kOrientationRadius + 1> build_orientation_umax();

/// Bin boundary vectors: boundary k (k = 0..B-1) is the direction 2*pi*(k - 0.5)/B scaled by 1024
/// and rounded, packed as (x, y) int32 pairs. Bin b holds the centroid vector m = (m10, m01) when
///   cross(u_b, m) >= 0 and cross(u_{b+1 mod B}, m) < 0, with cross(u, m) = u.x*m.y - u.y*m.x;
/// the first such b wins, and m = (0, 0) (no such b) gives bin 0. Bin b's centre is 2*pi*b/B.
std::vector<std::int32_t> build_orientation_boundaries(int bins);
double orientation_bin_center_rad(int bin, int bins);

// ---- Blur (§3.7) -------------------------------------------------------------------------------

/// 7 integer taps of a sigma-2 Gaussian summing to 256: outer taps rounded, the centre takes the
/// rest. Horizontal pass keeps h = sum t_i * p (uint16, unrounded); vertical pass gives
/// (sum t_j * h_j + 2^15) >> 16. Borders reflect-101 (see reflect101()).
std::array<std::int32_t, 7> build_blur_taps();

/// Reflect-101 index into [0, n): -1 -> 1, n -> n-2, repeated as needed; 0 when n == 1.
using contract::reflect101;

// ---- ORB descriptor (§3.8) ---------------------------------------------------------------------

inline constexpr int kOrbPairs = 256;
inline constexpr int kOrbPatternExtent = 13;  ///< unrotated points lie in [-13, 13]^2

/// The unrotated test pattern: 256 pairs (ax, ay, bx, by), drawn once from an isotropic Gaussian
/// (sigma = 31/5, the BRIEF G II scheme) with a fixed seed and clipped to [-13, 13].
const std::array<std::array<std::int8_t, 4>, kOrbPairs>& orb_base_pattern();

/// For each bin b, the pattern rotated by the bin's centre angle and rounded to integers:
/// bins * 256 * 4 int8 (ax, ay, bx, by). Rotated offsets stay within [-18, 18].
std::vector<std::int8_t> build_orb_pattern_table(int bins);

// ---- Stereo (§3.9) -----------------------------------------------------------------------------

/// Row search radius of a right keypoint of level n, in 1/256 level-0 px: round(2 * s^n * 256).
std::vector<std::int32_t> build_stereo_row_radius_q8(int levels, double scale);

// ---- All of a pipeline's tables ----------------------------------------------------------------

/// Everything a pipeline needs, built once from its settings and the level-0 image size.
struct FrontendTables {
  FrontendSettings settings;
  std::vector<std::pair<int, int>> level_sizes;
  std::vector<std::uint8_t> fast_lut;
  ResizeTables resize;
  std::vector<std::int32_t> scales_q16;
  CellLayout cells;
  std::array<int, kOrientationRadius + 1> umax{};
  std::vector<std::int32_t> orientation_boundaries;
  std::array<std::int32_t, 7> blur_taps{};
  std::vector<std::int8_t> orb_pattern;
  std::vector<std::int32_t> stereo_row_radius_q8;

  static FrontendTables build(const FrontendSettings& settings, int width, int height);
};

}  // namespace porta
