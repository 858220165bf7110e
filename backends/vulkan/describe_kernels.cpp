// Description kernels of the Vulkan backend: orientation and the ORB descriptor (DESIGN.md §3.6,
// §3.8); shaders orient.comp and orb_describe.comp. Both launch over the keypoint list's capacity
// and read the list's length on the device, so neither waits for the host. Argument checks mirror
// the cpu backend's (backends/cpu/describe_kernels.cpp); keypoints the cpu backend refuses from the
// list's contents (a level outside the pyramid, too close to the border, an angle bin outside the
// table) cannot be reported without reading the list on the host: the device leaves them alone.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "porta/tables.hpp"
#include "vulkan/vk_runtime.hpp"
#include "vulkan/vk_types.hpp"
#include "vulkan/vulkan_backend.hpp"

namespace porta::vulkan {

namespace {

struct OrientParams {  // orient.comp (parameter buffer)
  GlslLevels layout;
  std::int32_t umax[kOrientationRadius + 1];
  std::int32_t capacity;
  std::uint32_t count_offset;
  std::int32_t bins, pad;
};
struct OrbDescribeParams {  // orb_describe.comp (parameter buffer)
  GlslLevels layout;
  std::int32_t capacity;
  std::uint32_t count_offset;
  std::int32_t bins, pad;
};
static_assert(sizeof(OrientParams) == 208 + 64 + 16 && sizeof(OrbDescribeParams) == 208 + 16);
static_assert(sizeof(OrientParams) <= kMaxParamsBytes);

[[noreturn]] void fail(const char* call, const std::string& what) {
  throw BackendError(std::string("vulkan: ") + call + ": " + what);
}

void check_bins(const char* call, int bins) {
  // angle_bin is a uint8, so at most 256 bins can be told apart.
  if (bins < 1 || bins > 256) fail(call, "bins = " + std::to_string(bins) + " is outside [1, 256]");
}

}  // namespace

// §3.6: one invocation per list slot.
void VulkanBackend::orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
                           const std::array<int, 16>& umax, const Buffer& boundaries, int bins) {
  check_bins("orient", bins);
  if (boundaries.size_bytes() < static_cast<std::size_t>(bins) * 2 * sizeof(std::int32_t))
    fail("orient", "the boundary table holds fewer than " + std::to_string(bins) + " (x, y) pairs");
  OrientParams p{};
  for (int dy = 0; dy <= kOrientationRadius; ++dy) {
    const int u = umax[static_cast<std::size_t>(dy)];
    if (u < 0 || u > kOrientationRadius)
      fail("orient", "umax[" + std::to_string(dy) + "] = " + std::to_string(u) + " is outside [0, 15]");
    p.umax[dy] = u;
  }
  if (layout.element_bytes != 1) fail("orient", "the pyramid must hold 8-bit pixels");
  for (const Plane& plane : layout.levels) require_plane_inside(pyramid, plane, 1, "orient", "pyramid level");
  const int capacity = usable_capacity(keypoints, {{keypoints.items, sizeof(Keypoint)}}, "orient");
  if (capacity == 0) return;
  p.layout = to_glsl(layout, "orient");
  p.capacity = capacity;
  p.count_offset = static_cast<std::uint32_t>(keypoints.count_offset_bytes);
  p.bins = bins;
  rt().dispatch("orient", {&pyramid, keypoints.items, keypoints.count, &boundaries}, p,
                Work::items(static_cast<std::uint64_t>(capacity)));
}

// §3.8: one invocation per (list slot, 32-bit word of its descriptor).
void VulkanBackend::orb_describe(const Buffer& blurred, const PyramidLayout& layout,
                                 ConstDeviceList keypoints, const Buffer& pattern, Buffer& descriptors) {
  constexpr std::size_t kBinBytes = static_cast<std::size_t>(kOrbPairs) * 4;
  // The table's length gives the number of bins; angle_bin can name at most 256 of them.
  const std::size_t table_bins = pattern.size_bytes() / kBinBytes;
  const int bins = static_cast<int>(table_bins < 256 ? table_bins : 256);
  if (bins == 0) fail("orb_describe", "the pattern table holds no bin of 256 pairs");
  if (layout.element_bytes != 1) fail("orb_describe", "the pyramid must hold 8-bit pixels");
  for (const Plane& plane : layout.levels)
    require_plane_inside(blurred, plane, 1, "orb_describe", "blurred level");
  int capacity = usable_capacity(keypoints, {{keypoints.items, sizeof(Keypoint)}}, "orb_describe");
  const auto fits = static_cast<int>(std::min<std::size_t>(descriptors.size_bytes() / sizeof(Descriptor),
                                                           static_cast<std::size_t>(capacity)));
  if (fits < capacity) {
    // A descriptor buffer smaller than the list's capacity: only here is the count read on the
    // host (one round-trip), to refuse a list that does not fit as the cpu backend does.
    std::uint32_t count = 0;
    download(*keypoints.count, static_cast<std::size_t>(keypoints.count_offset_bytes), &count, sizeof(count));
    const std::int64_t n = std::min<std::int64_t>(count, keypoints.capacity);
    if (n > fits)
      fail("orb_describe", "the descriptor buffer holds fewer than " + std::to_string(n) + " descriptors");
    capacity = fits;
  }
  if (capacity == 0) return;
  OrbDescribeParams p{};
  p.layout = to_glsl(layout, "orb_describe");
  p.capacity = capacity;
  p.count_offset = static_cast<std::uint32_t>(keypoints.count_offset_bytes);
  p.bins = bins;
  rt().dispatch("orb_describe", {&blurred, keypoints.items, keypoints.count, &pattern, &descriptors}, p,
                Work::items(static_cast<std::uint64_t>(capacity) * 8));
}

}  // namespace porta::vulkan
