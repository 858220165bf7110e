// Detection kernels of the cpu backend: FAST corner response, per-cell culling, pyramidal feature
// aggregation (PFA) and the canonical compaction of the cell array. These are the reference
// definitions of DESIGN.md §3.3-3.5; every device backend must reproduce their bytes.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "cpu/cpu_backend.hpp"
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

}  // namespace

// §3.3 FAST CRF with bounded rectification: response = sum |I_i - c| over the 16-pixel circle when
// the bright or dark mask passes `lut`, else 0. Every pixel of every level's width x height is
// written, so pixels within `edge` of the border are 0 whatever the buffer held before.
void CpuBackend::fast_crf(const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                          Buffer& responses, const PyramidLayout& response_layout, const FastParams& params) {
  check_same_level_sizes(layout, response_layout, "fast_crf");
  checks::check_fast_edge("cpu", params);
  const std::uint8_t* pass = as<std::uint8_t>(lut);
  const int eps = params.threshold;
  const int edge = params.edge;

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
    std::fill(out, out + dst.width, std::uint16_t{0});
    if (y < edge || y >= src.height - edge) return;

    const std::uint8_t* row =
        as<std::uint8_t>(pyramid, src.offset_bytes) + static_cast<std::ptrdiff_t>(y) * src.pitch;
    const auto& offsets = circle_offsets[static_cast<std::size_t>(n)];
    for (int x = edge; x < src.width - edge; ++x) {
      const std::uint8_t* centre = row + x;
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
      if (pass[bright] | pass[dark]) out[x] = static_cast<std::uint16_t>(sum);
    }
  });
}

// §3.4 feature culling: the largest response of each cell as a Keypoint at
// cells[first_cell + row * cols + col]; the row-major scan with a strict '>' sends ties to the
// smaller row, then column. A cell whose maximum is 0 gets an all-zero record.
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
    const int y0 = cell_y * grid.cell_h;
    const int y1 = std::min(y0 + grid.cell_h, plane.height);
    for (int cell_x = 0; cell_x < grid.cols; ++cell_x) {
      const int x0 = cell_x * grid.cell_w;
      const int x1 = std::min(x0 + grid.cell_w, plane.width);
      std::uint16_t best = 0;
      int best_x = 0, best_y = 0;
      for (int y = y0; y < y1; ++y) {
        const std::uint16_t* row = level + static_cast<std::ptrdiff_t>(y) * plane.pitch;
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
        kp.level = static_cast<std::uint8_t>(n);
      }
      out[grid.first_cell + cell_y * grid.cols + cell_x] = kp;
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
