// Detection kernels of the cpu backend: FAST corner response, per-cell culling, pyramidal feature
// aggregation (PFA) and the canonical compaction of the cell array. These are the reference
// definitions of DESIGN.md §3.3-3.5; every device backend must reproduce their bytes.
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "cpu/simd.hpp"
#include "porta/kernel_checks.hpp"
#include "porta/tables.hpp"

namespace porta::cpu {

namespace {

/// Maps a flat job index to (level, row within the level) when the jobs of all levels are laid
/// end to end; `first_job[n]` is level n's first index and the last entry the total.
struct LevelRows {
  std::vector<std::int64_t> first_job;

  explicit LevelRows(const std::vector<int>& rows_per_level) {
    first_job.push_back(0);
    for (int rows : rows_per_level) first_job.push_back(first_job.back() + rows);
  }
  std::int64_t total() const { return first_job.back(); }
  std::pair<int, int> locate(std::int64_t job) const {
    const auto it = std::upper_bound(first_job.begin(), first_job.end(), job);
    const auto level = static_cast<int>(it - first_job.begin()) - 1;
    return {level, static_cast<int>(job - first_job[static_cast<std::size_t>(level)])};
  }
};

void check_same_level_sizes(const PyramidLayout& a, const PyramidLayout& b, const char* call) {
  checks::check_same_level_sizes("cpu", call, a, b);
}

using simd::i8x32;
using simd::u16x16;
using simd::u8x32;

/// True when any lane of `v` is non-zero (e.g. any lane of a comparison result is true).
template <typename V>
[[gnu::always_inline]] inline bool any_lane(const V& v) {
  std::uint64_t words[sizeof(V) / 8];
  std::memcpy(words, &v, sizeof(V));
  std::uint64_t any = 0;
  for (const std::uint64_t w : words) any |= w;
  return any != 0;
}

// ---- FAST CRF ----------------------------------------------------------------------------------

/// The reference FAST CRF of one pixel, straight from §3.3. `eps` is clamped to [-256, 256]
/// (which changes no test: |I_i - c| <= 255), so c +/- eps cannot overflow.
[[gnu::always_inline]] inline std::uint16_t fast_response(const std::uint8_t* centre,
                                                          const std::ptrdiff_t* offsets, int eps,
                                                          const std::uint8_t* pass) {
  const int c = *centre;
  unsigned bright = 0, dark = 0;
  int sum = 0;
  for (int i = 0; i < 16; ++i) {
    const int p = centre[offsets[i]];
    // Two independent tests, as in the contract (they only exclude each other for eps >= 0).
    if (p > c + eps) bright |= 1u << i;
    if (p < c - eps) dark |= 1u << i;
    sum += std::abs(p - c);
  }
  // 16 * 255 = 4080: the sum always fits the uint16 response.
  return (pass[bright] | pass[dark]) ? static_cast<std::uint16_t>(sum) : std::uint16_t{0};
}

/// What every mask the FAST table accepts has in common, for the vector step's early rejection:
/// its fewest set bits (17 when the table accepts none), and the opposite circle pixels {i, i + 8}
/// of which it always has at least one (bit i of `opposite_pairs`; all eight for any arc of 9 or
/// more, since such an arc spans half the circle and one more pixel). A pixel whose bright and dark
/// masks both fail either test cannot be a corner, whatever the table's shape. On rendered KITTI
/// images at the default threshold, 16 % of the pixels have 9 bright or 9 dark circle pixels but
/// only 6 % also one of every opposite pair (3.4 % are corners), so the pairs test keeps the
/// per-pixel table lookups of the vector step's second pass to 2.5x fewer pixels.
///
/// Whether the table is an arc table, too: exactly the masks whose longest circular run lies in
/// [arc_min, arc_max] pass (what build_fast_lut makes, for any 1 <= arc_min <= arc_max). The
/// vector step then tests the runs itself instead of looking the masks up one pixel at a time.
struct PassingMasks {
  int min_bits = 17;
  unsigned opposite_pairs = 0xFF;
  bool arc_table = false;
  int arc_min = 17, arc_max = 0;
};

/// longest_circular_run of every 16-bit mask, and how many masks have each run length.
struct RunLengths {
  std::array<std::uint8_t, 65536> of{};
  std::array<int, 17> count{};
  RunLengths() {
    for (unsigned m = 0; m < 65536; ++m) {
      of[m] = static_cast<std::uint8_t>(longest_circular_run(static_cast<std::uint16_t>(m)));
      ++count[of[m]];
    }
  }
};

PassingMasks passing_masks(const std::uint8_t* pass) {
  static const RunLengths runs;  // built once, on first use
  PassingMasks common;
  int passing = 0;
  for (unsigned mask = 0; mask < 65536; mask += 8) {
    std::uint64_t eight;  // most of a FAST table is zero: skip eight entries at a time
    std::memcpy(&eight, pass + mask, sizeof(eight));
    if (eight == 0) continue;
    for (unsigned m = mask; m < mask + 8; ++m) {
      if (pass[m] == 0) continue;
      common.min_bits = std::min(common.min_bits, std::popcount(m));
      common.opposite_pairs &= (m | (m >> 8)) & 0xFFu;  // pair i is hit when bit i or bit i + 8 is
      common.arc_min = std::min<int>(common.arc_min, runs.of[m]);
      common.arc_max = std::max<int>(common.arc_max, runs.of[m]);
      ++passing;
    }
  }
  // Every passing mask's run lies in [arc_min, arc_max]; when as many masks pass as have such a
  // run, those are all of them and no other passes.
  if (passing > 0 && common.arc_min >= 1) {
    int with_run = 0;
    for (int r = common.arc_min; r <= common.arc_max; ++r)
      with_run += runs.count[static_cast<std::size_t>(r)];
    common.arc_table = with_run == passing;
  }
  return common;
}

/// Sum |I_i - c| over the circle: the response of a pixel known to be a corner.
[[gnu::always_inline]] inline std::uint16_t circle_sum(const std::uint8_t* centre,
                                                       const std::ptrdiff_t* offsets) {
  int sum = 0;
  for (int i = 0; i < 16; ++i) sum += std::abs(centre[offsets[i]] - *centre);
  return static_cast<std::uint16_t>(sum);
}

// The arc test's helpers take and return vectors, so they are always inlined: a lambda or an
// out-of-line function would be one body shared by fast_crf_row's clones, whose vector ABIs differ
// (simd.hpp's rules).

/// `v` rotated so that bit j takes bit j + s (mod 16), per 16-bit lane; 0 <= s < 16.
[[gnu::always_inline]] inline simd::u16x16 rotate16(const simd::u16x16& v, int s) {
  return s == 0 ? v : static_cast<simd::u16x16>((v >> s) | (v << (16 - s)));
}

/// Lanes (nonzero) of the 16-bit masks `m` with a circular run of at least `k` ones, 1 <= k <= 16:
/// bit j of the result is set when bits j .. j + k - 1 (mod 16) all are, built from runs of 1, 2,
/// 4, 8 and 16 (each the last one and itself rotated by its length).
[[gnu::always_inline]] inline simd::u16x16 run_at_least(const simd::u16x16& m, int k) {
  simd::u16x16 run[5];
  run[0] = m;
  for (int b = 1; b < 5; ++b) run[b] = run[b - 1] & rotate16(run[b - 1], 1 << (b - 1));
  simd::u16x16 all = ~simd::u16x16{};
  int shift = 0;
  for (int b = 4; b >= 0; --b) {
    if ((k & (1 << b)) == 0) continue;
    all &= rotate16(run[b], shift);
    shift += 1 << b;
  }
  return all;
}

/// All ones in the lanes whose 16-bit mask has its longest circular run in [arc_min, arc_max].
[[gnu::always_inline]] inline simd::u16x16 arc_passes(const simd::u16x16& m, const PassingMasks& common) {
  const simd::u16x16 zero{};
  auto ok = static_cast<simd::u16x16>(run_at_least(m, common.arc_min) != zero);
  if (common.arc_max < 16) ok &= static_cast<simd::u16x16>(run_at_least(m, common.arc_max + 1) == zero);
  return ok;
}

/// Lanes 16h .. 16h + 15 of `v`.
[[gnu::always_inline]] inline simd::u8x16 half_of(const simd::u8x32& v, int h) {
  return simd::load<simd::u8x16>(reinterpret_cast<const std::uint8_t*>(&v) + 16 * h);
}

/// The 16-bit masks of lanes 16h .. 16h + 15 from their bits 0-7 (`low`) and 8-15 (`high`).
[[gnu::always_inline]] inline simd::u16x16 mask16(const simd::u8x32& low, const simd::u8x32& high, int h) {
  const simd::u16x16 bits_0_7 = simd::convert<simd::u16x16>(half_of(low, h));
  return static_cast<simd::u16x16>(bits_0_7 | (simd::convert<simd::u16x16>(half_of(high, h)) << 8));
}

/// The responses of 32 pixels at `centre` for an arc table, from their masks' bits 0-7 and 8-15 in
/// bytes: per lane, sum |I_i - c| when the bright or the dark mask has its longest run in
/// [arc_min, arc_max], else 0 (the reference's result for every lane).
[[gnu::always_inline]] inline void arc_corners(const std::uint8_t* centre, const std::ptrdiff_t* offsets,
                                               const simd::u8x32& c, const simd::u8x32& bright_low,
                                               const simd::u8x32& bright_high, const simd::u8x32& dark_low,
                                               const simd::u8x32& dark_high, const PassingMasks& common,
                                               std::uint16_t* out) {
  using simd::u16x16;
  using simd::u8x32;
  u16x16 sum[2] = {};
  for (int i = 0; i < 16; ++i) {
    const u8x32 p = simd::load<u8x32>(centre + offsets[i]);
    const u8x32 d = p > c ? static_cast<u8x32>(p - c) : static_cast<u8x32>(c - p);
    sum[0] += simd::convert<u16x16>(half_of(d, 0));
    sum[1] += simd::convert<u16x16>(half_of(d, 1));
  }
  for (int h = 0; h < 2; ++h) {
    const u16x16 bright = arc_passes(mask16(bright_low, bright_high, h), common);
    const u16x16 corner = bright | arc_passes(mask16(dark_low, dark_high, h), common);
    simd::store(out + 16 * h, static_cast<u16x16>(sum[h] & corner));
  }
}

/// Responses of pixels [x_begin, x_end) of one row (all at least 3 px inside the level), for
/// 0 <= eps <= 256. The vector step takes 32 pixels at a time and first only counts, per pixel,
/// the bright and dark circle pixels and checks the opposite pairs (PassingMasks): a pixel whose
/// masks fail both tests cannot pass, so a block without candidates is all zeros (most blocks).
/// Otherwise a second pass builds the masks: for an arc table (PassingMasks::arc_table) every lane
/// tests its runs and sums its circle in vectors; for any other table only the candidate pixels
/// look their masks up, and the corners then sum their circle.
PORTA_CPU_HOT void fast_crf_row(const std::uint8_t* row, const std::ptrdiff_t* offsets, int x_begin,
                                int x_end, int eps, const std::uint8_t* pass, const PassingMasks& common,
                                std::uint16_t* out) {
  constexpr int kLanes = 32;
  if (x_end - x_begin < kLanes) {
    for (int x = x_begin; x < x_end; ++x) out[x] = fast_response(row + x, offsets, eps, pass);
    return;
  }
  // eps >= 255 tests like eps = 255: no pixel is then above c + eps or below c - eps.
  const auto eps8 = static_cast<std::uint8_t>(std::min(eps, 255));
  const auto fewest = static_cast<std::int8_t>(common.min_bits);  // <= 17
  const std::uint8_t flip = 0x80;
  const u8x32 zero8{}, all_ones = zero8 + 0xFF;
  // Per opposite pair, all ones when the table does not require it (the test then always holds).
  i8x32 pair_free[8];
  for (int i = 0; i < 8; ++i) pair_free[i] = (i8x32)(((common.opposite_pairs >> i) & 1u) ? zero8 : all_ones);
  const u16x16 zero16{};
  for (int x = x_begin;; x += kLanes) {
    // The last block ends at x_end and may overlap the previous one (it recomputes the same values).
    x = std::min(x, x_end - kLanes);
    const std::uint8_t* centre = row + x;
    const u8x32 c = simd::load<u8x32>(centre);
    // c + eps and c - eps saturated to [0, 255]: where they wrap, "p > c + eps" (> 255) and
    // "p < c - eps" (< 0) never hold, and neither does p > 255 or p < 0.
    u8x32 above = c + eps8;
    above = above < c ? all_ones : above;
    u8x32 below = c - eps8;
    below = below > c ? zero8 : below;
    // Bytes with the top bit flipped compare as unsigned under signed (native) compares.
    const auto above_s = (i8x32)(above ^ flip);
    const auto below_s = (i8x32)(below ^ flip);
    // Per lane, minus the number of circle pixels brighter than c + eps, and darker than c - eps
    // (a true comparison is -1), and whether every required opposite pair has one of them.
    i8x32 bright_count{}, dark_count{};
    i8x32 bright_pairs = (i8x32)all_ones, dark_pairs = (i8x32)all_ones;
    for (int i = 0; i < 8; ++i) {
      const auto p = (i8x32)(simd::load<u8x32>(centre + offsets[i]) ^ flip);
      const auto q = (i8x32)(simd::load<u8x32>(centre + offsets[i + 8]) ^ flip);
      const i8x32 p_bright = p > above_s, q_bright = q > above_s;
      const i8x32 p_dark = p < below_s, q_dark = q < below_s;
      bright_count += p_bright + q_bright;
      dark_count += p_dark + q_dark;
      bright_pairs &= p_bright | q_bright | pair_free[i];
      dark_pairs &= p_dark | q_dark | pair_free[i];
    }
    simd::store(out + x, zero16);
    simd::store(out + x + 16, zero16);
    const i8x32 candidate = ((-bright_count >= fewest) & bright_pairs) | ((-dark_count >= fewest) & dark_pairs);
    if (any_lane(candidate)) {
      // The masks: bits 0-7 and bits 8-15 of each lane's bright and dark mask in separate bytes.
      u8x32 bright_low{}, bright_high{}, dark_low{}, dark_high{};
      for (int i = 0; i < 8; ++i) {
        const auto bit = static_cast<std::uint8_t>(1u << i);
        const auto p_low = (i8x32)(simd::load<u8x32>(centre + offsets[i]) ^ flip);
        const auto p_high = (i8x32)(simd::load<u8x32>(centre + offsets[i + 8]) ^ flip);
        bright_low |= (u8x32)(p_low > above_s) & bit;
        dark_low |= (u8x32)(p_low < below_s) & bit;
        bright_high |= (u8x32)(p_high > above_s) & bit;
        dark_high |= (u8x32)(p_high < below_s) & bit;
      }
      if (common.arc_table) {
        arc_corners(centre, offsets, c, bright_low, bright_high, dark_low, dark_high, common, out + x);
        if (x + kLanes >= x_end) break;
        continue;
      }
      std::uint8_t lanes[kLanes], b_low[kLanes], b_high[kLanes], d_low[kLanes], d_high[kLanes];
      simd::store(lanes, candidate);
      simd::store(b_low, bright_low);
      simd::store(b_high, bright_high);
      simd::store(d_low, dark_low);
      simd::store(d_high, dark_high);
      // Visit only the candidate lanes (0xFF bytes), eight lanes to a word.
      for (int first = 0; first < kLanes; first += 8) {
        std::uint64_t word;
        std::memcpy(&word, lanes + first, sizeof(word));
        while (word != 0) {
          const int bit = std::countr_zero(word) & ~7;
          word &= ~(std::uint64_t{0xFF} << bit);
          const int j = first + bit / 8;
          const unsigned bright = b_low[j] | (unsigned{b_high[j]} << 8);
          const unsigned dark = d_low[j] | (unsigned{d_high[j]} << 8);
          if (pass[bright] | pass[dark]) out[x + j] = circle_sum(centre + j, offsets);
        }
      }
    }
    if (x + kLanes >= x_end) break;
  }
}

// ---- Culling -----------------------------------------------------------------------------------

/// The reference culling of one cell [x0, x1) x [y0, y1): a row-major scan with a strict '>'
/// keeps the first maximum. Used where a level is too narrow for the vector path.
Keypoint cull_cell_scalar(const std::uint16_t* level, std::ptrdiff_t pitch, int x0, int x1, int y0, int y1,
                          int level_index) {
  std::uint16_t best = 0;
  int best_x = 0, best_y = 0;
  for (int y = y0; y < y1; ++y) {
    const std::uint16_t* row = level + static_cast<std::ptrdiff_t>(y) * pitch;
    for (int x = x0; x < x1; ++x) {
      if (row[x] > best) {
        best = row[x];
        best_x = x;
        best_y = y;
      }
    }
  }
  Keypoint kp{};
  if (best > 0) {
    kp.x = static_cast<std::uint16_t>(best_x);
    kp.y = static_cast<std::uint16_t>(best_y);
    kp.response = best;
    kp.level = static_cast<std::uint8_t>(level_index);
  }
  return kp;
}

/// The culling order as one integer: larger response first, then smaller row, then smaller
/// column (coordinates fit 16 bits, as in Keypoint), so a cell's winner is its largest key.
inline std::uint64_t cull_key(std::uint16_t response, int x, int y) {
  return (std::uint64_t{response} << 32) | (std::uint64_t{0xFFFFu - static_cast<unsigned>(y)} << 16) |
         std::uint64_t{0xFFFFu - static_cast<unsigned>(x)};
}

Keypoint keypoint_of(std::uint64_t key, int level_index) {
  Keypoint kp{};
  const auto response = static_cast<std::uint16_t>(key >> 32);
  if (response == 0) return kp;
  kp.x = static_cast<std::uint16_t>(0xFFFFu - (key & 0xFFFFu));
  kp.y = static_cast<std::uint16_t>(0xFFFFu - ((key >> 16) & 0xFFFFu));
  kp.response = response;
  kp.level = static_cast<std::uint8_t>(level_index);
  return kp;
}

/// One row of cells: rows [y0, y1) of the level, cells of `cell_w` columns over [0, x_limit),
/// x_limit >= 16; writes out[0, cols). The vector step takes 16 columns at a time down the rows
/// and keeps, per column, its maximum and the first row holding it; then the columns are folded
/// into their cells, in order, by the largest cull_key().
PORTA_CPU_HOT void cull_cell_row(const std::uint16_t* level, std::ptrdiff_t pitch, int x_limit, int y0,
                                 int y1, int cell_w, int cols, int level_index, Keypoint* out) {
  constexpr int kLanes = 16;
  std::uint16_t column_max[kLanes], column_row[kLanes];
  int cell = 0, cell_end = cell_w;  // the cell being folded and its first column past the end
  std::uint64_t best = 0;
  for (int x = 0, done = 0; done < x_limit; x += kLanes) {
    // The last strip ends at x_limit and may overlap the previous one; its columns below `done`
    // were folded already.
    const int xs = std::min(x, x_limit - kLanes);
    u16x16 max_v{}, row_v{};
    for (int y = y0; y < y1; ++y) {
      const u16x16 this_row = u16x16{} + static_cast<std::uint16_t>(y);
      const u16x16 v = simd::load<u16x16>(level + static_cast<std::ptrdiff_t>(y) * pitch + xs);
      const u16x16 higher = v > max_v ? v : max_v;
      // Only a strictly larger value moves a column's row: the first row of its maximum stays.
      row_v = higher == max_v ? row_v : this_row;
      max_v = higher;
    }
    simd::store(column_max, max_v);
    simd::store(column_row, row_v);
    for (int col = done; col < xs + kLanes; ++col) {
      if (col >= cell_end) {
        out[cell++] = keypoint_of(best, level_index);
        cell_end += cell_w;
        best = 0;
      }
      best = std::max(best, cull_key(column_max[col - xs], col, column_row[col - xs]));
    }
    done = xs + kLanes;
  }
  out[cell++] = keypoint_of(best, level_index);
  for (; cell < cols; ++cell) out[cell] = Keypoint{};  // cells wholly past the level's width
}

}  // namespace

// §3.3 FAST CRF with bounded rectification: response = sum |I_i - c| over the 16-pixel circle when
// the bright or dark mask passes `lut`, else 0. Every pixel of every level's width x height is
// written, so pixels within `edge` of the border are 0 whatever the buffer held before.
void CpuBackend::fast_crf(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                          Buffer& responses, const PyramidLayout& response_layout, const FastParams& params) {
  check_same_level_sizes(layout, response_layout, "fast_crf");
  checks::check_fast_edge("cpu", params);
  // The whole table is read (passing_masks), not only the entries of masks that occur.
  checks::check_bytes("cpu", "fast_crf", "the FAST table", lut, 65536);
  const std::uint8_t* pass = as<std::uint8_t>(lut);
  // |I_i - c| <= 255, so clamping eps to [-256, 256] changes no test and keeps c +/- eps in range.
  const int eps = std::clamp(params.threshold, -256, 256);
  const int edge = params.edge;
  const PassingMasks common = passing_masks(pass);

  std::vector<int> heights;
  std::vector<std::array<std::ptrdiff_t, 16>> circle_offsets;
  for (const Plane& p : layout.levels) {
    heights.push_back(p.height);
    std::array<std::ptrdiff_t, 16> offsets{};
    for (int i = 0; i < 16; ++i)
      offsets[i] = static_cast<std::ptrdiff_t>(kFastCircle[i].second) * p.pitch + kFastCircle[i].first;
    circle_offsets.push_back(offsets);
  }
  const LevelRows rows(heights);

  pool().parallel_for(0, rows.total(), [&](std::int64_t job) {
    const auto [n, y] = rows.locate(job);
    const Plane& src = layout.levels[n];
    const Plane& dst = response_layout.levels[n];
    std::uint16_t* out =
        as<std::uint16_t>(responses, dst.offset_bytes) + static_cast<std::ptrdiff_t>(y) * dst.pitch;
    const int x_begin = edge, x_end = src.width - edge;
    if (y < edge || y >= src.height - edge || x_begin >= x_end) {
      std::fill(out, out + dst.width, std::uint16_t{0});
      return;
    }
    std::fill(out, out + x_begin, std::uint16_t{0});
    std::fill(out + x_end, out + dst.width, std::uint16_t{0});

    const std::uint8_t* row =
        as<std::uint8_t>(pyramid, src.offset_bytes) + static_cast<std::ptrdiff_t>(y) * src.pitch;
    const std::ptrdiff_t* offsets = circle_offsets[static_cast<std::size_t>(n)].data();
    if (eps >= 0) {
      fast_crf_row(row, offsets, x_begin, x_end, eps, pass, common, out);
    } else {
      // A negative eps lets one circle pixel be both bright and dark: the counting bound of the
      // vector step does not cover it, so the plain loop runs.
      for (int x = x_begin; x < x_end; ++x) out[x] = fast_response(row + x, offsets, eps, pass);
    }
  });
}

// §3.4 feature culling: the largest response of each cell as a Keypoint at
// cells[first_cell + row * cols + col]; ties go to the smaller row, then column. A cell whose
// maximum is 0 gets an all-zero record.
void CpuBackend::cull_cells(const Buffer& responses, const PyramidLayout& response_layout,
                            const CellLayout& cell_layout, Buffer& cells) {
  if (static_cast<int>(cell_layout.levels.size()) != response_layout.num_levels())
    throw BackendError("cpu: cull_cells: the cell layout has " + std::to_string(cell_layout.levels.size()) +
                       " levels but the responses " + std::to_string(response_layout.num_levels()));
  std::vector<int> cell_rows;
  for (const LevelCells& c : cell_layout.levels) cell_rows.push_back(c.rows);
  const LevelRows rows(cell_rows);
  Keypoint* out = as<Keypoint>(cells);

  pool().parallel_for(0, rows.total(), [&](std::int64_t job) {
    const auto [n, cell_y] = rows.locate(job);
    const Plane& plane = response_layout.levels[n];
    const LevelCells& grid = cell_layout.levels[static_cast<std::size_t>(n)];
    const std::uint16_t* level = as<std::uint16_t>(responses, plane.offset_bytes);
    Keypoint* out_row = out + grid.first_cell + static_cast<std::ptrdiff_t>(cell_y) * grid.cols;
    const int y0 = cell_y * grid.cell_h;
    const int y1 = std::min(y0 + grid.cell_h, plane.height);
    // Columns that belong to some cell; cells past the level's width stay empty.
    const auto x_limit =
        static_cast<int>(std::min<std::int64_t>(plane.width, std::int64_t{grid.cols} * grid.cell_w));
    if (grid.cell_w > 0 && grid.cell_h > 0 && x_limit >= 16) {
      cull_cell_row(level, plane.pitch, x_limit, y0, y1, grid.cell_w, grid.cols, n, out_row);
      return;
    }
    for (int cell_x = 0; cell_x < grid.cols; ++cell_x) {
      const int x0 = cell_x * grid.cell_w;
      const int x1 = std::min(x0 + grid.cell_w, plane.width);
      out_row[cell_x] = cull_cell_scalar(level, plane.pitch, x0, x1, y0, y1, n);
    }
  });
}

// §3.5 PFA: keypoints projected to the same level-0 location L pool their score
// k_r(L) * k_l(L) (summed responses times distinct levels); a keypoint is cleared when a location
// in the q x q window around its L scores strictly more. All decisions use the unfiltered array.
void CpuBackend::pfa_filter(Buffer& cells, const CellLayout& cell_layout, const PfaParams& params) {
  const int width0 = params.level0_width, height0 = params.level0_height;
  if (width0 <= 0 || height0 <= 0)
    throw BackendError("cpu: pfa_filter: level-0 size " + std::to_string(width0) + "x" +
                       std::to_string(height0) + " is empty");
  Keypoint* kps = as<Keypoint>(cells);

  // Sparse form: one entry per keypoint, sorted by (location, level, cell) so that each location's
  // keypoints are contiguous, its levels counted in one pass, and locations ordered row-major.
  struct Projected {
    std::uint32_t location;  // Y * width0 + X; < 2^28 since sides are <= 16384
    std::uint8_t level;
    std::int32_t cell;
  };
  std::vector<Projected> projected;
  for (int i = 0; i < cell_layout.total_cells; ++i) {
    const Keypoint& kp = kps[i];
    if (kp.response == 0) continue;
    if (static_cast<std::size_t>(kp.level) >= params.scales_q16.size())
      throw BackendError("cpu: pfa_filter: keypoint of level " + std::to_string(kp.level) + " but only " +
                         std::to_string(params.scales_q16.size()) + " level scales");
    const auto scale = static_cast<std::uint64_t>(params.scales_q16[kp.level]);
    const auto x0 = std::min<std::uint64_t>((kp.x * scale) >> 16, static_cast<std::uint64_t>(width0 - 1));
    const auto y0 = std::min<std::uint64_t>((kp.y * scale) >> 16, static_cast<std::uint64_t>(height0 - 1));
    projected.push_back(
        {static_cast<std::uint32_t>(y0 * static_cast<std::uint64_t>(width0) + x0), kp.level, i});
  }
  std::sort(projected.begin(), projected.end(), [](const Projected& a, const Projected& b) {
    if (a.location != b.location) return a.location < b.location;
    if (a.level != b.level) return a.level < b.level;
    return a.cell < b.cell;
  });

  struct Location {
    std::uint32_t location;
    std::uint32_t score;
    std::size_t first, last;  // its keypoints: projected[first, last)
  };
  std::vector<Location> locations;
  for (std::size_t i = 0; i < projected.size();) {
    std::size_t j = i;
    std::uint32_t sum_response = 0, levels = 0;
    for (; j < projected.size() && projected[j].location == projected[i].location; ++j) {
      sum_response += kps[projected[j].cell].response;
      if (j == i || projected[j].level != projected[j - 1].level) ++levels;
    }
    locations.push_back({projected[i].location, sum_response * levels, i, j});
    i = j;
  }

  // Locations are sorted row-major, so each window row is one contiguous range found by binary search.
  const int half = params.window / 2;
  std::vector<std::uint8_t> survives(locations.size(), 1);
  const auto by_location = [](const Location& l, std::uint32_t value) { return l.location < value; };
  pool().parallel_for(0, static_cast<std::int64_t>(locations.size()), [&](std::int64_t k) {
    const Location& here = locations[static_cast<std::size_t>(k)];
    const int x = static_cast<int>(here.location % static_cast<std::uint32_t>(width0));
    const int y = static_cast<int>(here.location / static_cast<std::uint32_t>(width0));
    const int xa = std::max(0, x - half), xb = std::min(width0 - 1, x + half);
    for (int wy = std::max(0, y - half); wy <= std::min(height0 - 1, y + half); ++wy) {
      const auto row_start = static_cast<std::uint32_t>(wy) * static_cast<std::uint32_t>(width0);
      auto it = std::lower_bound(locations.begin(), locations.end(),
                                 row_start + static_cast<std::uint32_t>(xa), by_location);
      for (; it != locations.end() && it->location <= row_start + static_cast<std::uint32_t>(xb); ++it) {
        if (it->score > here.score) {
          survives[static_cast<std::size_t>(k)] = 0;
          return;
        }
      }
    }
  });

  for (std::size_t k = 0; k < locations.size(); ++k) {
    if (survives[k]) continue;
    for (std::size_t j = locations[k].first; j < locations[k].last; ++j) kps[projected[j].cell] = Keypoint{};
  }
}

// Canonical compaction: the non-empty cells (response > 0) in cell order, then their number as a
// uint32 at out.count + count_offset_bytes. Records past out.capacity are not written; the count
// is the full number of non-empty cells either way.
void CpuBackend::compact_keypoints(const Buffer& cells, int total_cells, DeviceList out) {
  const Keypoint* in = as<Keypoint>(cells);
  Keypoint* items = as<Keypoint>(*out.items);
  std::uint32_t count = 0;
  for (int i = 0; i < total_cells; ++i) {
    if (in[i].response == 0) continue;
    if (count < static_cast<std::uint32_t>(std::max(out.capacity, 0))) items[count] = in[i];
    ++count;
  }
  std::memcpy(as<std::uint8_t>(*out.count, out.count_offset_bytes), &count, sizeof(count));
}

}  // namespace porta::cpu
