// Argument checks and launch descriptions shared by the CUDA backend's *_ops.cpp files: the checks
// themselves are porta/kernel_checks.hpp's (shared by every backend), with the CUDA backend's name
// and plane limits; what is CUDA-specific here is the launch description. Internal to the backend.
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
#include "porta/kernel_checks.hpp"
#include "porta/layout.hpp"

namespace porta::cuda::detail {

inline constexpr const char* kBackend = "cuda";
// Kernels index planes of their element type from byte offsets of 64 bits.
inline constexpr checks::PlaneLimits kPlaneLimits{.aligned = true};

[[noreturn]] inline void fail(const char* call, const std::string& what) { checks::fail(kBackend, call, what); }

/// A kernel's launch status, as a BackendError naming the kernel.
inline void launched(cudaError_t status, const char* kernel) {
  check(status, std::string(kernel) + " launch");
}

inline void require_plane_inside(const Buffer& buffer, const Plane& plane, int element_bytes,
                                 const char* kernel, const char* what) {
  checks::check_plane(kBackend, kernel, what, buffer, plane, element_bytes, kPlaneLimits);
}

inline void require_bytes(const Buffer& buffer, std::int64_t bytes, const char* kernel,
                          const std::string& what) {
  checks::check_bytes(kBackend, kernel, what, buffer, bytes);
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
  checks::check_count_offset(kBackend, call, list);
}

using checks::usable_capacity;

/// The device view of a list's length.
inline DevCount count_of(const ConstDeviceList& list, int capacity) {
  if (capacity <= 0 || list.count == nullptr) return DevCount{nullptr, 0, 0};
  return DevCount{dev<std::uint8_t>(*list.count, list.count_offset_bytes), capacity, 0};
}

}  // namespace porta::cuda::detail
