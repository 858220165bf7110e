// Orientation and ORB descriptor contracts of the CUDA backend (DESIGN.md §3.6, §3.8): argument
// checks, then the launches of describe_kernels.cu over the keypoint list's capacity; the list's
// length is read on the device, so neither waits for the host.
#include <algorithm>
#include <string>

#include "cuda/host_checks.hpp"
#include "porta/tables.hpp"

namespace porta::cuda {

// §3.6. Keypoints the cpu backend refuses (a level outside the pyramid, closer than 15 px to the
// border) cannot be reported without reading the list on the host; the device leaves them unchanged.
void CudaBackend::orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
                         const std::array<int, 16>& umax, const Buffer& boundaries, int bins) {
  checks::check_orient_tables(detail::kBackend, umax, boundaries, bins);
  DevUmax u{};
  for (int dy = 0; dy <= kOrientationRadius; ++dy) u.v[dy] = umax[static_cast<std::size_t>(dy)];
  checks::check_8bit_pixels(detail::kBackend, "orient", layout);
  const DevLevels levels = detail::to_dev(layout, "orient");
  const ConstDeviceList list(keypoints);
  detail::check_count_offset("orient", list);
  const int capacity = detail::usable_capacity(list, {{list.items, sizeof(Keypoint)}});
  if (capacity == 0) return;
  activate();
  enqueue<&launch_orient>("orient", dev<std::uint8_t>(pyramid), levels, dev<DevKeypoint>(*keypoints.items),
                          detail::count_of(list, capacity), u, dev<std::int32_t>(boundaries), bins);
}

// §3.8. As for orient, a keypoint the cpu backend refuses (bad level, closer than 18 px to the
// border, angle bin outside the table) keeps whatever its descriptor slot held.
void CudaBackend::orb_describe(const Buffer& blurred, const PyramidLayout& layout, ConstDeviceList keypoints,
                               const Buffer& pattern, Buffer& descriptors) {
  const int bins = checks::orb_pattern_bins(detail::kBackend, pattern);
  checks::check_8bit_pixels(detail::kBackend, "orb_describe", layout);
  const DevLevels levels = detail::to_dev(layout, "orb_describe");
  detail::check_count_offset("orb_describe", keypoints);
  const int capacity = checks::descriptor_capacity(
      *this, detail::kBackend, keypoints,
      detail::usable_capacity(keypoints, {{keypoints.items, sizeof(Keypoint)}}), descriptors);
  if (capacity == 0) return;
  activate();
  enqueue<&launch_orb_describe>("orb_describe", dev<std::uint8_t>(blurred), levels,
                                dev<DevKeypoint>(*keypoints.items), detail::count_of(keypoints, capacity),
                                dev<std::int8_t>(pattern), bins, dev<std::uint8_t>(descriptors));
}

}  // namespace porta::cuda
