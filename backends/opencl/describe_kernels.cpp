// Orientation and ORB descriptor kernels of the OpenCL backend (DESIGN.md §3.6, §3.8): host side of
// shaders/opencl/describe.cl. Both launch over the keypoint list's capacity; the list's length is
// read on the device, so neither waits for the host.
#include <algorithm>
#include <string>

#include "opencl/cl_types.hpp"
#include "opencl/opencl_backend.hpp"
#include "porta/tables.hpp"

namespace porta::opencl {

namespace {

/// Host mirror of describe.cl's describe_umax.
struct ClUmax {
  cl_int v[kOrientationRadius + 1];
};
static_assert(sizeof(ClUmax) == 16 * 4);

[[noreturn]] void fail(const char* call, const std::string& what) {
  throw BackendError(std::string("opencl: ") + call + ": " + what);
}

void check_bins(const char* call, int bins) {
  // angle_bin is a uint8, so at most 256 bins can be told apart.
  if (bins < 1 || bins > 256) fail(call, "bins = " + std::to_string(bins) + " is outside [1, 256]");
}

/// The slots a kernel may touch: the list's capacity, but never past the end of its items buffer
/// (the cpu backend reads only `count` records; a capacity larger than the buffer must not make the
/// device read outside it).
int usable_capacity(const ConstDeviceList& list, std::size_t record_bytes) {
  if (!list.items || !list.count || list.capacity <= 0) return 0;
  const auto fits = static_cast<std::int64_t>(list.items->size_bytes() / record_bytes);
  return static_cast<int>(std::min<std::int64_t>(list.capacity, fits));
}

void check_count_offset(const char* call, const ConstDeviceList& list) {
  if (list.count && (list.count_offset_bytes < 0 ||
                     static_cast<std::uint64_t>(list.count_offset_bytes) + 4 > list.count->size_bytes()))
    fail(call, "the list's count at byte " + std::to_string(list.count_offset_bytes) +
                   " lies outside its buffer of " + std::to_string(list.count->size_bytes()) + " bytes");
}

}  // namespace

// §3.6. Keypoints the cpu backend refuses (a level outside the pyramid, closer than 15 px to the
// border) cannot be reported without reading the list on the host; the device leaves them unchanged.
void OpenClBackend::orient(const Buffer& pyramid, const PyramidLayout& layout, DeviceList keypoints,
                           const std::array<int, 16>& umax, const Buffer& boundaries, int bins) {
  check_bins("orient", bins);
  if (boundaries.size_bytes() < static_cast<std::size_t>(bins) * 2 * sizeof(std::int32_t))
    fail("orient", "the boundary table holds fewer than " + std::to_string(bins) + " (x, y) pairs");
  ClUmax u{};
  for (int dy = 0; dy <= kOrientationRadius; ++dy) {
    if (umax[static_cast<std::size_t>(dy)] < 0 || umax[static_cast<std::size_t>(dy)] > kOrientationRadius)
      fail("orient", "umax[" + std::to_string(dy) +
                         "] = " + std::to_string(umax[static_cast<std::size_t>(dy)]) + " is outside [0, 15]");
    u.v[dy] = umax[static_cast<std::size_t>(dy)];
  }
  if (layout.element_bytes != 1) fail("orient", "the pyramid must hold 8-bit pixels");
  const ConstDeviceList list(keypoints);
  check_count_offset("orient", list);
  const int capacity = usable_capacity(list, sizeof(Keypoint));
  if (capacity == 0) return;
  launch("describe", "orient", Range::linear(static_cast<std::size_t>(capacity)), pyramid, to_cl(layout),
         *keypoints.items, *keypoints.count, static_cast<cl_long>(keypoints.count_offset_bytes),
         static_cast<cl_int>(capacity), u, boundaries, static_cast<cl_int>(bins));
}

// §3.8. As for orient, a keypoint the cpu backend refuses (bad level, closer than 18 px to the
// border, angle bin outside the table) keeps whatever its descriptor slot held.
void OpenClBackend::orb_describe(const Buffer& blurred, const PyramidLayout& layout,
                                 ConstDeviceList keypoints, const Buffer& pattern, Buffer& descriptors) {
  constexpr std::size_t kBinBytes = static_cast<std::size_t>(kOrbPairs) * 4;
  // The table's length gives the number of bins; angle_bin can name at most 256 of them.
  const std::size_t table_bins = pattern.size_bytes() / kBinBytes;
  const int bins = static_cast<int>(table_bins < 256 ? table_bins : 256);
  if (bins == 0) fail("orb_describe", "the pattern table holds no bin of 256 pairs");
  if (layout.element_bytes != 1) fail("orb_describe", "the pyramid must hold 8-bit pixels");
  check_count_offset("orb_describe", keypoints);
  int capacity = usable_capacity(keypoints, sizeof(Keypoint));
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
  launch("describe", "orb_describe", Range::linear(static_cast<std::size_t>(capacity) * 32), blurred,
         to_cl(layout), *keypoints.items, *keypoints.count,
         static_cast<cl_long>(keypoints.count_offset_bytes), static_cast<cl_int>(capacity), pattern,
         static_cast<cl_int>(bins), descriptors);
}

}  // namespace porta::opencl
