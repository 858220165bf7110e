// Stereo matching and projection matching of the OpenCL backend (DESIGN.md §3.9, §3.10): host side
// of shaders/opencl/match.cl. Every kernel launches over a list's capacity and reads the list's
// length on the device; no call waits for the host.
#include <algorithm>
#include <initializer_list>
#include <string>
#include <utility>

#include "opencl/cl_types.hpp"
#include "opencl/opencl_backend.hpp"
#include "porta/kernel_checks.hpp"

namespace porta::opencl {

namespace {

// Must match match.cl: MATCH_SAD_VALUES fine bins, MATCH_SAD_BLOCKS coarse bins, the median.
constexpr std::size_t kSadValues = 61711;  // a centred 11x11 SAD is at most 121 * 510
constexpr std::size_t kSadBlocks = (kSadValues + 255) / 256;
constexpr std::size_t kHistogramBytes = (kSadValues + kSadBlocks + 1) * sizeof(cl_uint);

/// The first `n` values of a per-level table, by value (the rest zero).
ClLevelInts first_levels(const std::vector<std::int32_t>& v, std::size_t n) {
  ClLevelInts out{};
  for (std::size_t i = 0; i < std::min<std::size_t>({n, v.size(), static_cast<std::size_t>(kMaxLevels)}); ++i)
    out.v[i] = v[i];
  return out;
}

void check_count_offset(const char* call, const ConstDeviceList& list) {
  checks::check_count_offset("opencl", call, list);
}

using checks::usable_capacity;

}  // namespace

// §3.9 in three launches: candidates (steps a-e, one work-item per left keypoint, a full scan of the
// right list in index order, which the tie rule makes equal to the cpu's row-bucketed search; each
// accepted SAD counted in a histogram), median (one work-item walks the histogram) and reject.
void OpenClBackend::stereo_match(const Buffer& left_pyramid, const Buffer& right_pyramid,
                                 const PyramidLayout& layout, ConstDeviceList left_keypoints,
                                 const Buffer& left_descriptors, ConstDeviceList right_keypoints,
                                 const Buffer& right_descriptors, const StereoParams& params,
                                 Buffer& matches) {
  const auto levels = static_cast<std::size_t>(layout.num_levels());
  checks::check_stereo_tables("opencl", layout, params);
  const ClLevels cl_layout = to_cl(layout);  // refuses more than 12 levels
  check_count_offset("stereo_match", left_keypoints);
  check_count_offset("stereo_match", right_keypoints);
  const int left_capacity = usable_capacity(left_keypoints, {{left_keypoints.items, sizeof(Keypoint)},
                                                             {&left_descriptors, sizeof(Descriptor)},
                                                             {&matches, sizeof(StereoMatch)}});
  if (left_capacity == 0) return;
  const int right_capacity = usable_capacity(
      right_keypoints, {{right_keypoints.items, sizeof(Keypoint)}, {&right_descriptors, sizeof(Descriptor)}});
  // An empty right list still needs a buffer argument; its count then reads as 0 slots.
  const Buffer& right_items = right_keypoints.items ? *right_keypoints.items : left_descriptors;
  const Buffer& right_count = right_keypoints.count ? *right_keypoints.count : *left_keypoints.count;

  Buffer& sads = scratch("stereo_match.sads", static_cast<std::size_t>(left_capacity) * sizeof(cl_int));
  Buffer& histogram = scratch("stereo_match.histogram", kHistogramBytes);
  fill(histogram, 0, kHistogramBytes, 0);
  const Range per_left = Range::linear(static_cast<std::size_t>(left_capacity));
  // A GPU scans the right list with a 64-wide work-group per left keypoint; a CPU device (PoCL),
  // whose work-items run as loops, with one work-item each (work_groups()). The same bytes.
  const bool grouped = work_groups();
  launch("match", grouped ? "stereo_match_candidates_group" : "stereo_match_candidates",
         grouped ? Range::linear(static_cast<std::size_t>(left_capacity) * 64, 64) : per_left, left_pyramid,
         right_pyramid, cl_layout,
         *left_keypoints.items, *left_keypoints.count,
         static_cast<cl_long>(left_keypoints.count_offset_bytes), static_cast<cl_int>(left_capacity),
         left_descriptors, right_items, right_count, static_cast<cl_long>(right_keypoints.count_offset_bytes),
         static_cast<cl_int>(right_capacity), right_descriptors, first_levels(params.scales_q16, levels),
         first_levels(params.row_radius_q8, levels), static_cast<cl_int>(params.min_disparity_q8),
         static_cast<cl_int>(params.max_disparity_q8), static_cast<cl_int>(params.max_hamming), matches, sads,
         histogram);
  launch("match", "stereo_match_median", Range::linear(1), histogram);
  launch("match", "stereo_match_reject", per_left, *left_keypoints.count,
         static_cast<cl_long>(left_keypoints.count_offset_bytes), static_cast<cl_int>(left_capacity), sads,
         histogram, matches);
}

// §3.10: one work-item per query, a full scan of the keypoint list in index order.
void OpenClBackend::projection_match(ConstDeviceList keypoints, const Buffer& keypoint_descriptors,
                                     const Buffer& queries, const Buffer& query_descriptors, int num_queries,
                                     const std::vector<std::int32_t>& scales_q16, Buffer& results) {
  check_count_offset("projection_match", keypoints);
  // Never past the end of a query-side buffer (the cpu backend trusts num_queries).
  const std::int64_t n = checks::usable_queries(num_queries, queries, query_descriptors, results);
  if (n == 0) return;
  const int capacity = usable_capacity(
      keypoints, {{keypoints.items, sizeof(Keypoint)}, {&keypoint_descriptors, sizeof(Descriptor)}});
  // A keypoint's level is a uint8: scales past 256 entries name no level.
  const std::size_t num_scales = std::min<std::size_t>(scales_q16.size(), 256);
  // Scales of levels >= 12 (no pyramid has them, but the contract allows such a table) go to the
  // device through a scratch buffer; only then is there an upload, which waits for the queue.
  Buffer* more = &scratch("projection_match.more_scales", sizeof(cl_int));
  if (num_scales > static_cast<std::size_t>(kMaxLevels)) {
    const std::size_t extra = num_scales - static_cast<std::size_t>(kMaxLevels);
    more = &scratch("projection_match.more_scales", extra * sizeof(cl_int));
    upload(*more, 0, scales_q16.data() + kMaxLevels, extra * sizeof(cl_int));
  }
  const Buffer& items = keypoints.items ? *keypoints.items : keypoint_descriptors;
  const Buffer& count = keypoints.count ? *keypoints.count : *more;
  launch("match", "projection_match", Range::linear(static_cast<std::size_t>(n)), items, count,
         static_cast<cl_long>(keypoints.count_offset_bytes), static_cast<cl_int>(capacity),
         keypoint_descriptors, queries, query_descriptors, static_cast<cl_int>(n),
         first_levels(scales_q16, num_scales), *more, static_cast<cl_int>(num_scales), results);
}

}  // namespace porta::opencl
