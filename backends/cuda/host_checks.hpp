// Argument checks and launch descriptions shared by the CUDA backend's *_ops.cpp files: what the
// kernels index with is checked on the host before a launch, so that a bad argument is an error
// naming it instead of a device fault. Internal to the backend.
#pragma once

#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <utility>

#include "cuda/cuda_backend.hpp"
#include "cuda/cuda_errors.hpp"
#include "cuda/kernels.hpp"
#include "porta/layout.hpp"

namespace porta::cuda::detail {

[[noreturn]] inline void fail(const char* call, const std::string& what) {
  throw BackendError(std::string("cuda: ") + call + ": " + what);
}

/// A kernel's launch status, as a BackendError naming the kernel.
inline void launched(cudaError_t status, const char* kernel) {
  check(status, std::string(kernel) + " launch");
}

inline void require_plane_inside(const Buffer& buffer, const Plane& plane, int element_bytes,
                                 const char* kernel, const char* what) {
  if (plane.width <= 0 || plane.height <= 0) return;
  const std::int64_t end_bytes =
      plane.offset_bytes +
      (static_cast<std::int64_t>(plane.height - 1) * plane.pitch + plane.width) * element_bytes;
  if (plane.offset_bytes < 0 || plane.pitch < plane.width || plane.offset_bytes % element_bytes != 0 ||
      end_bytes > static_cast<std::int64_t>(buffer.size_bytes()))
    fail(kernel, std::string(what) + " plane (offset " + std::to_string(plane.offset_bytes) + " bytes, " +
                     std::to_string(plane.width) + "x" + std::to_string(plane.height) + ", pitch " +
                     std::to_string(plane.pitch) + ") does not fit its buffer of " +
                     std::to_string(buffer.size_bytes()) + " bytes");
}

inline void require_bytes(const Buffer& buffer, std::int64_t bytes, const char* kernel,
                          const std::string& what) {
  if (bytes > static_cast<std::int64_t>(buffer.size_bytes()))
    fail(kernel, what + " needs " + std::to_string(bytes) + " bytes but its buffer has " +
                     std::to_string(buffer.size_bytes()));
}

inline void require_levels(int levels, const char* kernel) {
  if (levels > kMaxLevels)
    fail(kernel, std::to_string(levels) + " pyramid levels; at most " + std::to_string(kMaxLevels));
}

inline DevPlane to_dev(const Plane& p) { return DevPlane{p.offset_bytes, p.width, p.height, p.pitch, 0}; }

inline DevLevels to_dev(const PyramidLayout& layout, const char* kernel) {
  require_levels(layout.num_levels(), kernel);
  DevLevels l{};
  l.count = layout.num_levels();
  for (int n = 0; n < l.count; ++n) l.level[n] = to_dev(layout.levels[static_cast<std::size_t>(n)]);
  return l;
}

/// The levels of `layout` with launch blocks of kTileW x kTileH pixels assigned level by level;
/// empty levels get none.
inline DevTiledLevels tile_levels(const PyramidLayout& layout, const char* kernel) {
  require_levels(layout.num_levels(), kernel);
  DevTiledLevels t{};
  t.count = layout.num_levels();
  std::int64_t blocks = 0;
  for (int n = 0; n < t.count; ++n) {
    const Plane& p = layout.levels[static_cast<std::size_t>(n)];
    t.level[n] = to_dev(p);
    t.first_block[n] = static_cast<int>(blocks);
    if (p.width <= 0 || p.height <= 0) continue;
    t.tiles_x[n] = (p.width + kTileW - 1) / kTileW;
    blocks += static_cast<std::int64_t>(t.tiles_x[n]) * ((p.height + kTileH - 1) / kTileH);
    if (blocks > std::numeric_limits<int>::max())
      fail(kernel, "the pyramid has too many pixels for one launch");
  }
  t.first_block[t.count] = static_cast<int>(blocks);
  return t;
}

inline void check_count_offset(const char* call, const ConstDeviceList& list) {
  if (list.count && (list.count_offset_bytes < 0 ||
                     static_cast<std::uint64_t>(list.count_offset_bytes) + 4 > list.count->size_bytes()))
    fail(call, "the list's count at byte " + std::to_string(list.count_offset_bytes) +
                   " lies outside its buffer of " + std::to_string(list.count->size_bytes()) + " bytes");
}

/// The list slots a kernel may touch: the capacity, but never more records than each of `buffers`
/// (with its record size) holds. The cpu backend reads only `count` records, so a capacity larger
/// than a buffer is no error as long as the count fits; the device must not read past the end.
inline int usable_capacity(const ConstDeviceList& list,
                           std::initializer_list<std::pair<const Buffer*, std::size_t>> buffers) {
  if (!list.items || !list.count || list.capacity <= 0) return 0;
  std::int64_t n = list.capacity;
  for (const auto& [buffer, record_bytes] : buffers)
    n = std::min<std::int64_t>(n, static_cast<std::int64_t>(buffer->size_bytes() / record_bytes));
  return static_cast<int>(n);
}

/// The device view of a list's length.
inline DevCount count_of(const ConstDeviceList& list, int capacity) {
  if (capacity <= 0 || list.count == nullptr) return DevCount{nullptr, 0, 0};
  return DevCount{dev<std::uint8_t>(*list.count, list.count_offset_bytes), capacity, 0};
}

}  // namespace porta::cuda::detail
