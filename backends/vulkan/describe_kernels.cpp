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

}  // namespace

// §3.6: one workgroup of 32 per list slot (a row of the disc each), reduced in shared memory; on a
// CPU device one invocation per slot (orient_per_item.comp). The same bytes.
void VulkanBackend::orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
                           const std::array<int, 16>& umax, const Buffer& boundaries, int bins) {
  checks::check_orient_tables(kBackend, umax, boundaries, bins);
  OrientParams p{};
  for (int dy = 0; dy <= kOrientationRadius; ++dy) p.umax[dy] = umax[static_cast<std::size_t>(dy)];
  checks::check_8bit_pixels(kBackend, "orient", layout);
  for (const Plane& plane : layout.levels) require_plane_inside(pyramid, plane, 1, "orient", "pyramid level");
  const int capacity = usable_capacity(keypoints, {{keypoints.items, sizeof(Keypoint)}}, "orient");
  if (capacity == 0) return;
  p.layout = to_glsl(layout, "orient");
  p.capacity = capacity;
  p.count_offset = static_cast<std::uint32_t>(keypoints.count_offset_bytes);
  p.bins = bins;
  if (work_groups()) {
    rt().dispatch("orient", {&pyramid, keypoints.items, keypoints.count, &boundaries}, p,
                  Work::groups(static_cast<std::uint64_t>(capacity)));
  } else {
    rt().dispatch("orient_per_item", {&pyramid, keypoints.items, keypoints.count, &boundaries}, p,
                  Work::items(static_cast<std::uint64_t>(capacity)));
  }
}

// §3.8: one invocation per (list slot, 32-bit word of its descriptor).
void VulkanBackend::orb_describe(const Buffer& blurred, const PyramidLayout& layout,
                                 ConstDeviceList keypoints, const Buffer& pattern, Buffer& descriptors) {
  const int bins = checks::orb_pattern_bins(kBackend, pattern);
  checks::check_8bit_pixels(kBackend, "orb_describe", layout);
  for (const Plane& plane : layout.levels)
    require_plane_inside(blurred, plane, 1, "orb_describe", "blurred level");
  const int capacity = checks::descriptor_capacity(
      *this, kBackend, keypoints,
      usable_capacity(keypoints, {{keypoints.items, sizeof(Keypoint)}}, "orb_describe"), descriptors);
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
