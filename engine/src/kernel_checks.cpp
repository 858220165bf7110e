#include "porta/kernel_checks.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdlib>

#include "porta/tables.hpp"

namespace porta::checks {

void fail(std::string_view backend, std::string_view kernel, const std::string& what) {
  std::string message;
  message.reserve(backend.size() + kernel.size() + what.size() + 4);
  message.append(backend).append(": ").append(kernel).append(": ").append(what);
  throw BackendError(message);
}

void check_plane(std::string_view backend, std::string_view kernel, std::string_view what, const Buffer& buffer,
                 const Plane& plane, int element_bytes, const PlaneLimits& limits) {
  if (plane.width <= 0 || plane.height <= 0) return;
  const std::int64_t end_bytes =
      plane.offset_bytes +
      (static_cast<std::int64_t>(plane.height - 1) * plane.pitch + plane.width) * element_bytes;
  if (plane.offset_bytes < 0 || plane.pitch < plane.width ||
      (limits.aligned && plane.offset_bytes % element_bytes != 0) ||
      end_bytes > static_cast<std::int64_t>(buffer.size_bytes()) || plane.offset_bytes > limits.max_offset ||
      end_bytes > limits.max_end)
    fail(backend, kernel,
         std::string(what) + " plane (offset " + std::to_string(plane.offset_bytes) + " bytes, " +
             std::to_string(plane.width) + "x" + std::to_string(plane.height) + ", pitch " +
             std::to_string(plane.pitch) + ") does not fit its buffer of " + std::to_string(buffer.size_bytes()) +
             " bytes");
}

void check_bytes(std::string_view backend, std::string_view kernel, std::string_view what, const Buffer& buffer,
                 std::int64_t bytes) {
  if (bytes > static_cast<std::int64_t>(buffer.size_bytes()))
    fail(backend, kernel,
         std::string(what) + " needs " + std::to_string(bytes) + " bytes but its buffer has " +
             std::to_string(buffer.size_bytes()));
}

void check_same_level_sizes(std::string_view backend, std::string_view kernel, const PyramidLayout& a,
                            const PyramidLayout& b) {
  bool same = a.levels.size() == b.levels.size();
  for (std::size_t n = 0; same && n < a.levels.size(); ++n)
    same = a.levels[n].width == b.levels[n].width && a.levels[n].height == b.levels[n].height;
  if (!same) fail(backend, kernel, "the two layouts do not have the same level sizes");
}

void check_pyramid(std::string_view backend, const Buffer& pyramid, const PyramidLayout& layout,
                   const Buffer& resize_table, const std::vector<std::int32_t>& level_offset,
                   bool reject_negative_offsets, const PlaneLimits& limits) {
  const int levels = layout.num_levels();
  if (levels > 1 && static_cast<int>(level_offset.size()) < levels - 1)
    fail(backend, "build_pyramid",
         std::to_string(level_offset.size()) + " level offsets given for " + std::to_string(levels) +
             " levels (need levels - 1)");
  for (const Plane& level : layout.levels) check_plane(backend, "build_pyramid", "level", pyramid, level, 1, limits);
  for (int n = 1; n < levels; ++n) {
    const Plane& level = layout.levels[static_cast<std::size_t>(n)];
    const std::int64_t offset = level_offset[static_cast<std::size_t>(n - 1)];
    if (reject_negative_offsets && offset < 0)
      fail(backend, "build_pyramid",
           "negative resize table offset " + std::to_string(offset) + " for level " + std::to_string(n));
    check_bytes(backend, "build_pyramid", "the resize table of level " + std::to_string(n), resize_table,
                (offset + 2 * static_cast<std::int64_t>(level.width) + 2 * level.height) * 4);
  }
}

void check_rectify(std::string_view backend, const Buffer& src, const Plane& src_plane, const Buffer& map,
                   const Buffer& dst, const Plane& dst_plane, const PlaneLimits& limits) {
  check_plane(backend, "rectify", "source", src, src_plane, 1, limits);
  check_plane(backend, "rectify", "destination", dst, dst_plane, 1, limits);
  check_bytes(backend, "rectify", "the map", map,
              static_cast<std::int64_t>(dst_plane.width) * dst_plane.height * 2 * 4);
}

void check_blur(std::string_view backend, const Buffer& pyramid, const PyramidLayout& layout,
                const Buffer& blurred, const std::array<std::int32_t, 7>& taps, const PlaneLimits& limits) {
  std::int32_t tap_sum = 0;
  for (const std::int32_t t : taps) {
    if (t < 0) fail(backend, "blur", "taps must be non-negative (see build_blur_taps())");
    tap_sum += t;
  }
  if (tap_sum != 256)
    fail(backend, "blur", "taps sum to " + std::to_string(tap_sum) + ", must sum to 256 (see build_blur_taps())");
  for (const Plane& level : layout.levels) {
    check_plane(backend, "blur", "pyramid level", pyramid, level, 1, limits);
    check_plane(backend, "blur", "blurred level", blurred, level, 1, limits);
  }
}

void check_orient_tables(std::string_view backend, const std::array<int, 16>& umax, const Buffer& boundaries,
                         int bins) {
  // angle_bin is a uint8, so at most 256 bins can be told apart.
  if (bins < 1 || bins > 256) fail(backend, "orient", "bins = " + std::to_string(bins) + " is outside [1, 256]");
  if (boundaries.size_bytes() < static_cast<std::size_t>(bins) * 2 * sizeof(std::int32_t))
    fail(backend, "orient", "the boundary table holds fewer than " + std::to_string(bins) + " (x, y) pairs");
  for (int dy = 0; dy <= kOrientationRadius; ++dy) {
    const int u = umax[static_cast<std::size_t>(dy)];
    if (u < 0 || u > kOrientationRadius)
      fail(backend, "orient", "umax[" + std::to_string(dy) + "] = " + std::to_string(u) + " is outside [0, 15]");
  }
}

void check_8bit_pixels(std::string_view backend, std::string_view kernel, const PyramidLayout& layout) {
  if (layout.element_bytes != 1) fail(backend, kernel, "the pyramid must hold 8-bit pixels");
}

int orb_pattern_bins(std::string_view backend, const Buffer& pattern) {
  constexpr std::size_t kBinBytes = static_cast<std::size_t>(kOrbPairs) * 4;
  const std::size_t table_bins = pattern.size_bytes() / kBinBytes;
  const int bins = static_cast<int>(table_bins < 256 ? table_bins : 256);
  if (bins == 0) fail(backend, "orb_describe", "the pattern table holds no bin of 256 pairs");
  return bins;
}

void check_stereo_tables(std::string_view backend, const PyramidLayout& layout, const StereoParams& params) {
  const auto levels = static_cast<std::size_t>(layout.num_levels());
  if (params.scales_q16.size() < levels || params.row_radius_q8.size() < levels)
    fail(backend, "stereo_match",
         "the layout has " + std::to_string(levels) + " levels but scales_q16 has " +
             std::to_string(params.scales_q16.size()) + " and row_radius_q8 " +
             std::to_string(params.row_radius_q8.size()) + " entries; give one per level");
}

std::int64_t usable_queries(int num_queries, const Buffer& queries, const Buffer& query_descriptors,
                            const Buffer& results) {
  std::int64_t n = std::max(num_queries, 0);
  n = std::min<std::int64_t>(n, static_cast<std::int64_t>(queries.size_bytes() / sizeof(ProjectionQuery)));
  n = std::min<std::int64_t>(n, static_cast<std::int64_t>(query_descriptors.size_bytes() / sizeof(Descriptor)));
  n = std::min<std::int64_t>(n, static_cast<std::int64_t>(results.size_bytes() / sizeof(ProjectionResult)));
  return n;
}

void check_fast_edge(std::string_view backend, const FastParams& params) {
  if (params.edge < 3)
    fail(backend, "fast_crf",
         "edge " + std::to_string(params.edge) + " is below 3, the radius of the FAST circle; allowed: >= 3");
}

void check_fast(std::string_view backend, const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                const Buffer& responses, const PyramidLayout& response_layout, const FastParams& params,
                const PlaneLimits& limits) {
  check_same_level_sizes(backend, "fast_crf", layout, response_layout);
  check_fast_edge(backend, params);
  check_bytes(backend, "fast_crf", "the FAST table", lut, 65536);
  for (const Plane& p : layout.levels) check_plane(backend, "fast_crf", "pyramid level", pyramid, p, 1, limits);
  for (const Plane& p : response_layout.levels)
    check_plane(backend, "fast_crf", "response level", responses, p, 2, limits);
}

std::int64_t check_cull(std::string_view backend, const Buffer& responses, const PyramidLayout& response_layout,
                        const CellLayout& cell_layout, const Buffer& cells, std::int64_t max_cell_pixels,
                        const PlaneLimits& limits) {
  if (static_cast<int>(cell_layout.levels.size()) != response_layout.num_levels())
    fail(backend, "cull_cells",
         "the cell layout has " + std::to_string(cell_layout.levels.size()) + " levels but the responses " +
             std::to_string(response_layout.num_levels()));
  std::int64_t end_cell = 0;
  for (const LevelCells& c : cell_layout.levels) {
    const bool bad_size = max_cell_pixels > 0 && (c.cell_w <= 0 || c.cell_h <= 0 ||
                                                  static_cast<std::int64_t>(c.cell_w) * c.cell_h > max_cell_pixels);
    if (c.cols < 0 || c.rows < 0 || c.first_cell < 0 || bad_size)
      fail(backend, "cull_cells",
           "invalid cell grid (" + std::to_string(c.cols) + "x" + std::to_string(c.rows) + " cells of " +
               std::to_string(c.cell_w) + "x" + std::to_string(c.cell_h) + " from cell " +
               std::to_string(c.first_cell) + ")");
    end_cell = std::max(end_cell, static_cast<std::int64_t>(c.first_cell) + c.count());
  }
  for (const Plane& p : response_layout.levels)
    check_plane(backend, "cull_cells", "response level", responses, p, 2, limits);
  check_bytes(backend, "cull_cells", "the cell array", cells, end_cell * static_cast<std::int64_t>(sizeof(Keypoint)));
  return end_cell;
}

PfaSetup check_pfa(std::string_view backend, const Buffer& cells, const CellLayout& cell_layout,
                   const PfaParams& params, std::int64_t max_pixels0) {
  const int width0 = params.level0_width, height0 = params.level0_height;
  if (width0 <= 0 || height0 <= 0)
    fail(backend, "pfa_filter",
         "level-0 size " + std::to_string(width0) + "x" + std::to_string(height0) + " is empty");
  // The cpu backend throws when it meets a keypoint of a level without a scale; a device cannot
  // throw, so every cell level must have one (cull_cells writes keypoints of those levels only).
  if (params.scales_q16.size() < cell_layout.levels.size())
    fail(backend, "pfa_filter",
         std::to_string(params.scales_q16.size()) + " level scales for " + std::to_string(cell_layout.levels.size()) +
             " cell levels");
  if (static_cast<std::int64_t>(width0) * height0 > max_pixels0)
    fail(backend, "pfa_filter",
         "level-0 size " + std::to_string(width0) + "x" + std::to_string(height0) + " is too large");
  PfaSetup p;
  const int total = cell_layout.total_cells;
  if (total <= 0) return p;
  check_bytes(backend, "pfa_filter", "the cell array", cells,
              static_cast<std::int64_t>(total) * static_cast<std::int64_t>(sizeof(Keypoint)));
  p.num_scales = static_cast<std::int32_t>(std::min(params.scales_q16.size(), p.scales.size()));
  for (int n = 0; n < p.num_scales; ++n) p.scales[static_cast<std::size_t>(n)] = params.scales_q16[static_cast<std::size_t>(n)];
  p.total_cells = total;
  p.width0 = width0;
  p.height0 = height0;
  p.reach = params.window / 2;
  return p;
}

std::int64_t compact_capacity(std::string_view backend, const Buffer& cells, int total_cells,
                              const DeviceList& out) {
  if (out.count == nullptr) fail(backend, "compact_keypoints", "the list has no count buffer");
  if (out.count_offset_bytes < 0)
    fail(backend, "compact_keypoints", "negative count offset " + std::to_string(out.count_offset_bytes));
  check_bytes(backend, "compact_keypoints", "the count", *out.count, out.count_offset_bytes + 4);
  const int total = std::max(total_cells, 0);
  check_bytes(backend, "compact_keypoints", "the cell array", cells,
              static_cast<std::int64_t>(total) * static_cast<std::int64_t>(sizeof(Keypoint)));
  if (out.items == nullptr) return 0;
  return std::min<std::int64_t>(std::max(out.capacity, 0),
                                static_cast<std::int64_t>(out.items->size_bytes() / sizeof(Keypoint)));
}

int descriptor_capacity(Backend& device, std::string_view backend, const ConstDeviceList& keypoints, int capacity,
                        const Buffer& descriptors) {
  const auto fits = static_cast<int>(
      std::min<std::size_t>(descriptors.size_bytes() / sizeof(Descriptor), static_cast<std::size_t>(capacity)));
  if (fits >= capacity) return capacity;
  std::uint32_t count = 0;
  device.download(*keypoints.count, static_cast<std::size_t>(keypoints.count_offset_bytes), &count, sizeof(count));
  const std::int64_t n = std::min<std::int64_t>(count, keypoints.capacity);
  if (n > fits)
    fail(backend, "orb_describe", "the descriptor buffer holds fewer than " + std::to_string(n) + " descriptors");
  return fits;
}

void check_count_offset(std::string_view backend, std::string_view kernel, const ConstDeviceList& list,
                        std::int64_t max_offset) {
  if (list.count != nullptr &&
      (list.count_offset_bytes < 0 || list.count_offset_bytes > max_offset ||
       static_cast<std::uint64_t>(list.count_offset_bytes) + 4 > list.count->size_bytes()))
    fail(backend, kernel,
         "the list's count at byte " + std::to_string(list.count_offset_bytes) + " lies outside its buffer of " +
             std::to_string(list.count->size_bytes()) + " bytes");
}

int usable_capacity(const ConstDeviceList& list,
                    std::initializer_list<std::pair<const Buffer*, std::size_t>> buffers) {
  if (list.items == nullptr || list.count == nullptr || list.capacity <= 0) return 0;
  std::int64_t n = list.capacity;
  for (const auto& [buffer, record_bytes] : buffers)
    n = std::min<std::int64_t>(n, static_cast<std::int64_t>(buffer->size_bytes() / record_bytes));
  return static_cast<int>(n);
}

int env_int(std::string_view backend, const char* variable, int lo, int hi, int fallback, std::string_view what) {
  const char* env = std::getenv(variable);
  if (env == nullptr || *env == '\0') return fallback;
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(env, &end, 10);
  if (end == env || *end != '\0' || errno != 0 || n < lo || n > hi)
    throw BackendError(std::string(backend) + ": " + variable + " must be " + std::string(what) + " from " +
                       std::to_string(lo) + " to " + std::to_string(hi) + ", got '" + env + "'");
  return static_cast<int>(n);
}

bool env_switch(std::string_view backend, const char* variable, bool fallback) {
  const char* env = std::getenv(variable);
  if (env == nullptr || *env == '\0') return fallback;
  const std::string value = env;
  if (value != "on" && value != "off")
    throw BackendError(std::string(backend) + ": " + variable + " must be on or off, got '" + value + "'");
  return value == "on";
}

int fused_pyramid_levels(const PyramidLayout& layout, int tile_w, int tile_h, std::int64_t capacity_bytes) {
  const int levels = layout.num_levels();
  std::vector<std::pair<int, int>> sizes;
  int usable = 0;  // levels 0..usable-1 are not empty
  for (const Plane& p : layout.levels) {
    if (p.width <= 0 || p.height <= 0) break;
    sizes.emplace_back(p.width, p.height);
    ++usable;
  }
  if (usable < 2) return 0;
  const ResizeTables tables = build_resize_tables(sizes);
  int fused = 1;  // level 1 reads level 0 only: always
  for (int n = 2; n < std::min(levels, usable); ++n) {
    const auto [w, h] = sizes[static_cast<std::size_t>(n)];
    bool fits = true;
    for (int ty = 0; ty < h && fits; ty += tile_h) {
      for (int tx = 0; tx < w && fits; tx += tile_w) {
        int xa = tx, xb = std::min(tx + tile_w, w) - 1, ya = ty, yb = std::min(ty + tile_h, h) - 1;
        for (int k = n; k >= 2; --k) {  // the region of level k - 1 that level k's region reads
          const ResizeAxis& cols = tables.cols[static_cast<std::size_t>(k - 1)];
          const ResizeAxis& rows = tables.rows[static_cast<std::size_t>(k - 1)];
          const auto [aw, ah] = sizes[static_cast<std::size_t>(k - 1)];
          xa = cols.src0[static_cast<std::size_t>(xa)];
          xb = std::min(cols.src0[static_cast<std::size_t>(xb)] + 1, aw - 1);
          ya = rows.src0[static_cast<std::size_t>(ya)];
          yb = std::min(rows.src0[static_cast<std::size_t>(yb)] + 1, ah - 1);
          const std::int64_t padded = (static_cast<std::int64_t>(xb - xa + 1) + 3) / 4 * 4;
          if (padded * (yb - ya + 1) > capacity_bytes) {
            fits = false;
            break;
          }
        }
      }
    }
    if (!fits) break;
    fused = n;
  }
  return fused;
}

int FusedPyramidLevels::operator()(const PyramidLayout& layout) {
  std::vector<std::int32_t> key;
  for (const Plane& p : layout.levels) key.insert(key.end(), {p.width, p.height});
  auto it = known_.find(key);
  if (it == known_.end()) it = known_.emplace(key, fused_pyramid_levels(layout, tile_w_, tile_h_, capacity_)).first;
  return it->second;
}

LevelTiles tile_levels(std::string_view backend, std::string_view kernel, const PyramidLayout& layout, int tile_w,
                       int tile_h) {
  LevelTiles t;
  const auto levels = static_cast<std::size_t>(layout.num_levels());
  t.first.assign(levels + 1, 0);
  t.across.assign(levels, 0);
  std::int64_t tiles = 0;
  for (std::size_t n = 0; n < levels; ++n) {
    const Plane& p = layout.levels[n];
    t.first[n] = static_cast<std::int32_t>(tiles);
    if (p.width <= 0 || p.height <= 0) continue;
    t.across[n] = (p.width + tile_w - 1) / tile_w;
    tiles += static_cast<std::int64_t>(t.across[n]) * ((p.height + tile_h - 1) / tile_h);
    if (tiles > std::numeric_limits<std::int32_t>::max())
      fail(backend, kernel, "the pyramid has too many pixels for one dispatch");
  }
  t.first[levels] = static_cast<std::int32_t>(tiles);
  return t;
}

CellGroups plan_cell_groups(std::string_view backend, std::string_view kernel, const CellLayout& cells,
                            int group_size, int pixels_per_invocation) {
  CellGroups g;
  int group_shift = 0;
  while ((1 << (group_shift + 1)) <= group_size) ++group_shift;
  std::int64_t grid_pixels = 0;
  for (const LevelCells& c : cells.levels) grid_pixels += static_cast<std::int64_t>(c.count()) * c.cell_w * c.cell_h;
  const bool small = grid_pixels < kSmallGridPixels;
  const std::int64_t per_invocation = pixels_per_invocation > 0 ? pixels_per_invocation : 4;
  for (const LevelCells& c : cells.levels) {
    const std::int64_t pixels = static_cast<std::int64_t>(c.cell_w) * c.cell_h;
    int shift = 0;
    if (small || pixels_per_invocation > 0) {
      while (shift < group_shift && (std::int64_t{1} << shift) * per_invocation < pixels) ++shift;
    } else {
      shift = std::min(6, group_shift);
    }
    g.first_group.push_back(static_cast<std::int32_t>(g.groups));
    g.shift.push_back(shift);
    const std::int64_t per_group = std::int64_t{1} << (group_shift - shift);
    g.groups += (static_cast<std::int64_t>(c.count()) + per_group - 1) / per_group;
    if (g.groups > std::numeric_limits<std::int32_t>::max())
      fail(backend, kernel, std::to_string(g.groups) + " workgroups of " + std::to_string(group_size) +
                                " for the cells; at most 2^31 - 1");
  }
  return g;
}

}  // namespace porta::checks
