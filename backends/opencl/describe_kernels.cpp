// Orientation and ORB descriptor kernels of the OpenCL backend (DESIGN.md §3.6, §3.8): host side of
// shaders/opencl/describe.cl. Both launch over the keypoint list's capacity; the list's length is
// read on the device, so neither waits for the host.
#include <algorithm>
#include <string>

#include "opencl/cl_types.hpp"
#include "opencl/opencl_backend.hpp"
#include "porta/kernel_checks.hpp"
#include "porta/tables.hpp"

namespace porta::opencl {

namespace {

/// Host mirror of describe.cl's describe_umax.
struct ClUmax {
  cl_int v[kOrientationRadius + 1];
};
static_assert(sizeof(ClUmax) == 16 * 4);

/// The slots a kernel may touch: the list's capacity, but never past the end of its items buffer.
int usable_capacity(const ConstDeviceList& list, std::size_t record_bytes) {
  return checks::usable_capacity(list, {{list.items, record_bytes}});
}

void check_count_offset(const char* call, const ConstDeviceList& list) {
  checks::check_count_offset("opencl", call, list);
}

}  // namespace

// §3.6. Keypoints the cpu backend refuses (a level outside the pyramid, closer than 15 px to the
// border) cannot be reported without reading the list on the host; the device leaves them unchanged.
void OpenClBackend::orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
                           const std::array<int, 16>& umax, const Buffer& boundaries, int bins) {
  checks::check_orient_tables("opencl", umax, boundaries, bins);
  ClUmax u{};
  for (int dy = 0; dy <= kOrientationRadius; ++dy) u.v[dy] = umax[static_cast<std::size_t>(dy)];
  checks::check_8bit_pixels("opencl", "orient", layout);
  const ConstDeviceList list(keypoints);
  check_count_offset("orient", list);
  const int capacity = usable_capacity(list, sizeof(Keypoint));
  if (capacity == 0) return;
  // GPUs: a 32-wide work-group per slot (orient_group); CPU devices: a work-item. The same bytes.
  const auto slots = static_cast<std::size_t>(capacity);
  launch("describe", work_groups() ? "orient_group" : "orient",
         work_groups() ? Range::linear(slots * 32, 32) : Range::linear(slots), pyramid, to_cl(layout),
         *keypoints.items, *keypoints.count, static_cast<cl_long>(keypoints.count_offset_bytes),
         static_cast<cl_int>(capacity), u, boundaries, static_cast<cl_int>(bins));
}

// §3.8. As for orient, a keypoint the cpu backend refuses (bad level, closer than 18 px to the
// border, angle bin outside the table) keeps whatever its descriptor slot held.
void OpenClBackend::orb_describe(const Buffer& blurred, const PyramidLayout& layout,
                                 ConstDeviceList keypoints, const Buffer& pattern, Buffer& descriptors) {
  const int bins = checks::orb_pattern_bins("opencl", pattern);
  checks::check_8bit_pixels("opencl", "orb_describe", layout);
  check_count_offset("orb_describe", keypoints);
  const int capacity = checks::descriptor_capacity(
      *this, "opencl", keypoints,
      usable_capacity(keypoints, sizeof(Keypoint)), descriptors);
  if (capacity == 0) return;
  launch("describe", "orb_describe", Range::linear(static_cast<std::size_t>(capacity) * 32), blurred,
         to_cl(layout), *keypoints.items, *keypoints.count,
         static_cast<cl_long>(keypoints.count_offset_bytes), static_cast<cl_int>(capacity), pattern,
         static_cast<cl_int>(bins), descriptors);
}

}  // namespace porta::opencl
