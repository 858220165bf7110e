// Host mirrors of the structs of shaders/vulkan/common.glsl (std430 layout, passed as push
// constants or in the parameter buffer), and the argument checks the kernel files share.
// Internal to backends/vulkan.
#pragma once

#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "porta/backend.hpp"
#include "porta/layout.hpp"

namespace porta::vulkan {

inline constexpr int kMaxLevels = 12;

struct GlslPlane {
  std::int32_t offset_bytes, width, height, pitch;
};
struct GlslLevels {
  GlslPlane level[kMaxLevels];
  std::int32_t count, pad[3];
};
struct GlslLevelCells {
  std::int32_t cell_w, cell_h, cols, rows, first_cell, pad[3];
};
struct GlslCells {
  GlslLevelCells level[kMaxLevels];
  std::int32_t count, total_cells, pad[2];
};
static_assert(sizeof(GlslPlane) == 16);
static_assert(sizeof(GlslLevels) == 12 * 16 + 16);
static_assert(sizeof(GlslCells) == 12 * 32 + 16);

inline GlslPlane to_glsl(const Plane& p) {
  return {static_cast<std::int32_t>(p.offset_bytes), p.width, p.height, p.pitch};
}

inline GlslLevels to_glsl(const PyramidLayout& layout, const char* kernel) {
  if (layout.num_levels() > kMaxLevels)
    throw BackendError(std::string("vulkan: ") + kernel + ": " + std::to_string(layout.num_levels()) +
                       " levels; at most 12");
  GlslLevels l{};
  l.count = layout.num_levels();
  for (int n = 0; n < l.count; ++n) l.level[n] = to_glsl(layout.levels[static_cast<std::size_t>(n)]);
  return l;
}

inline GlslCells to_glsl(const CellLayout& cells, const char* kernel) {
  if (cells.levels.size() > static_cast<std::size_t>(kMaxLevels))
    throw BackendError(std::string("vulkan: ") + kernel + ": " + std::to_string(cells.levels.size()) +
                       " cell levels; at most 12");
  GlslCells c{};
  c.count = static_cast<std::int32_t>(cells.levels.size());
  c.total_cells = cells.total_cells;
  for (std::size_t n = 0; n < cells.levels.size(); ++n) {
    const auto& l = cells.levels[n];
    c.level[n] = {l.cell_w, l.cell_h, l.cols, l.rows, l.first_cell, {0, 0, 0}};
  }
  return c;
}

/// A kernel reading or writing outside its buffer would corrupt device memory silently; say which.
/// Shaders index with int32, so planes must also end below 2^31 bytes.
inline void require_plane_inside(const Buffer& buffer, const Plane& plane, int element_bytes,
                                 const char* kernel, const char* what) {
  if (plane.width <= 0 || plane.height <= 0) return;
  const std::int64_t end_bytes =
      plane.offset_bytes +
      (static_cast<std::int64_t>(plane.height - 1) * plane.pitch + plane.width) * element_bytes;
  if (plane.offset_bytes < 0 || plane.pitch < plane.width || plane.offset_bytes % element_bytes != 0 ||
      end_bytes > static_cast<std::int64_t>(buffer.size_bytes()) ||
      end_bytes > std::numeric_limits<std::int32_t>::max())
    throw BackendError(std::string("vulkan: ") + kernel + ": " + what + " plane (offset " +
                       std::to_string(plane.offset_bytes) + " bytes, " + std::to_string(plane.width) + "x" +
                       std::to_string(plane.height) + ", pitch " + std::to_string(plane.pitch) +
                       ") does not fit its buffer of " + std::to_string(buffer.size_bytes()) + " bytes");
}

inline void require_bytes(const Buffer& buffer, std::int64_t bytes, const char* kernel,
                          const std::string& what) {
  if (bytes > static_cast<std::int64_t>(buffer.size_bytes()))
    throw BackendError(std::string("vulkan: ") + kernel + ": " + what + " needs " + std::to_string(bytes) +
                       " bytes but its buffer has " + std::to_string(buffer.size_bytes()));
}

inline void check_same_level_sizes(const PyramidLayout& a, const PyramidLayout& b, const char* kernel) {
  bool same = a.num_levels() == b.num_levels();
  for (std::size_t n = 0; same && n < a.levels.size(); ++n)
    same = a.levels[n].width == b.levels[n].width && a.levels[n].height == b.levels[n].height;
  if (!same)
    throw BackendError(std::string("vulkan: ") + kernel +
                       ": the two layouts do not have the same level sizes");
}

/// `layout` with empty levels given no rows, for shaders that lay the rows of all levels end to
/// end; also the widest level and the total number of rows.
inline GlslLevels rows_of_levels(const PyramidLayout& layout, const char* kernel, std::uint64_t& max_width,
                                 std::uint64_t& rows) {
  GlslLevels l = to_glsl(layout, kernel);
  max_width = 0;
  rows = 0;
  for (int n = 0; n < l.count; ++n) {
    if (l.level[n].width <= 0 || l.level[n].height <= 0) {
      l.level[n].width = 0;
      l.level[n].height = 0;
      continue;
    }
    max_width = std::max<std::uint64_t>(max_width, static_cast<std::uint64_t>(l.level[n].width));
    rows += static_cast<std::uint64_t>(l.level[n].height);
  }
  return l;
}

/// The list slots a kernel launched over a device list's capacity may touch: the capacity, but
/// never more records than each of `buffers` (with its record size) holds. The cpu backend reads
/// only `count` records, so a capacity larger than a buffer is no error as long as the count fits;
/// the device must not read past the end. 0 for a list without items or count. Also refuses a
/// count that does not lie inside its buffer (the shaders read it at a uint32 byte offset).
inline int usable_capacity(const ConstDeviceList& list,
                           std::initializer_list<std::pair<const Buffer*, std::size_t>> buffers,
                           const char* kernel) {
  if (list.count != nullptr &&
      (list.count_offset_bytes < 0 || list.count_offset_bytes > std::numeric_limits<std::int32_t>::max() ||
       static_cast<std::uint64_t>(list.count_offset_bytes) + 4 > list.count->size_bytes()))
    throw BackendError(std::string("vulkan: ") + kernel + ": the list's count at byte " +
                       std::to_string(list.count_offset_bytes) + " lies outside its buffer of " +
                       std::to_string(list.count->size_bytes()) + " bytes");
  if (list.items == nullptr || list.count == nullptr || list.capacity <= 0) return 0;
  std::int64_t n = list.capacity;
  for (const auto& [buffer, record_bytes] : buffers)
    n = std::min<std::int64_t>(n, static_cast<std::int64_t>(buffer->size_bytes() / record_bytes));
  return static_cast<int>(n);
}

}  // namespace porta::vulkan
