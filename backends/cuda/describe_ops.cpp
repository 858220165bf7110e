// Orientation and ORB descriptor contracts of the CUDA backend (DESIGN.md §3.6, §3.8): argument
// checks, then the launches of describe_kernels.cu over the keypoint list's capacity; the list's
// length is read on the device, so neither waits for the host.
#include <algorithm>
#include <string>

#include "cuda/host_checks.hpp"
#include "porta/tables.hpp"

namespace porta::cuda {

using detail::fail;

namespace {

void check_bins(const char* call, int bins) {
  // angle_bin is a uint8, so at most 256 bins can be told apart.
  if (bins < 1 || bins > 256) fail(call, "bins = " + std::to_string(bins) + " is outside [1, 256]");
}

}  // namespace

// §3.6. Keypoints the cpu backend refuses (a level outside the pyramid, closer than 15 px to the
// border) cannot be reported without reading the list on the host; the device leaves them unchanged.
void CudaBackend::orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
                         const std::array<int, 16>& umax, const Buffer& boundaries, int bins) {
  check_bins("orient", bins);
  if (boundaries.size_bytes() < static_cast<std::size_t>(bins) * 2 * sizeof(std::int32_t))
    fail("orient", "the boundary table holds fewer than " + std::to_string(bins) + " (x, y) pairs");
  DevUmax u{};
  for (int dy = 0; dy <= kOrientationRadius; ++dy) {
    if (umax[static_cast<std::size_t>(dy)] < 0 || umax[static_cast<std::size_t>(dy)] > kOrientationRadius)
      fail("orient", "umax[" + std::to_string(dy) +
                         "] = " + std::to_string(umax[static_cast<std::size_t>(dy)]) + " is outside [0, 15]");
    u.v[dy] = umax[static_cast<std::size_t>(dy)];
  }
  if (layout.element_bytes != 1) fail("orient", "the pyramid must hold 8-bit pixels");
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
  constexpr std::size_t kBinBytes = static_cast<std::size_t>(kOrbPairs) * 4;
  // The table's length gives the number of bins; angle_bin can name at most 256 of them.
  const std::size_t table_bins = pattern.size_bytes() / kBinBytes;
  const int bins = static_cast<int>(table_bins < 256 ? table_bins : 256);
  if (bins == 0) fail("orb_describe", "the pattern table holds no bin of 256 pairs");
  if (layout.element_bytes != 1) fail("orb_describe", "the pyramid must hold 8-bit pixels");
  const DevLevels levels = detail::to_dev(layout, "orb_describe");
  detail::check_count_offset("orb_describe", keypoints);
  int capacity = detail::usable_capacity(keypoints, {{keypoints.items, sizeof(Keypoint)}});
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
  activate();
  enqueue<&launch_orb_describe>("orb_describe", dev<std::uint8_t>(blurred), levels,
                                dev<DevKeypoint>(*keypoints.items), detail::count_of(keypoints, capacity),
                                dev<std::int8_t>(pattern), bins, dev<std::uint8_t>(descriptors));
}

}  // namespace porta::cuda
