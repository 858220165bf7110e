// Stereo matching and projection matching contracts of the CUDA backend (DESIGN.md §3.9, §3.10):
// argument checks, then the launches of match_kernels.cu. Every kernel launches over a list's
// capacity and reads the list's length on the device; no call waits for the host.
#include <algorithm>
#include <string>
#include <vector>

#include "cuda/host_checks.hpp"

namespace porta::cuda {

// §3.9 in two launches: candidates (steps a-e, a warp per left keypoint scanning the right list,
// each accepted SAD counted in a histogram), then one block for the median and the rejection.
void CudaBackend::stereo_match(const Buffer& left_pyramid, const Buffer& right_pyramid,
                               const PyramidLayout& layout, ConstDeviceList left_keypoints,
                               const Buffer& left_descriptors, ConstDeviceList right_keypoints,
                               const Buffer& right_descriptors, const StereoParams& params, Buffer& matches) {
  const auto levels = static_cast<std::size_t>(layout.num_levels());
  checks::check_stereo_tables(detail::kBackend, layout, params);
  StereoLaunch launch{};
  launch.layout = detail::to_dev(layout, "stereo_match");  // refuses more than 12 levels
  for (std::size_t n = 0; n < levels; ++n) {
    launch.scales_q16[n] = params.scales_q16[n];
    launch.row_radius_q8[n] = params.row_radius_q8[n];
  }
  launch.min_disparity_q8 = params.min_disparity_q8;
  launch.max_disparity_q8 = params.max_disparity_q8;
  launch.max_hamming = params.max_hamming;
  detail::check_count_offset("stereo_match", left_keypoints);
  detail::check_count_offset("stereo_match", right_keypoints);
  const int left_capacity = detail::usable_capacity(left_keypoints, {{left_keypoints.items, sizeof(Keypoint)},
                                                                     {&left_descriptors, sizeof(Descriptor)},
                                                                     {&matches, sizeof(StereoMatch)}});
  if (left_capacity == 0) return;
  const int right_capacity = detail::usable_capacity(
      right_keypoints, {{right_keypoints.items, sizeof(Keypoint)}, {&right_descriptors, sizeof(Descriptor)}});
  activate();
  Buffer& sads = scratch("stereo_match.sads", static_cast<std::size_t>(left_capacity) * sizeof(std::int32_t));
  Buffer& histogram =
      scratch("stereo_match.histogram", static_cast<std::size_t>(kHistogramWords) * sizeof(std::uint32_t));
  enqueue<&launch_stereo_match>(
      "stereo_match", dev<std::uint8_t>(left_pyramid), dev<std::uint8_t>(right_pyramid),
      dev<DevKeypoint>(*left_keypoints.items), detail::count_of(left_keypoints, left_capacity),
      dev<std::uint8_t>(left_descriptors),
      right_capacity > 0 ? dev<DevKeypoint>(*right_keypoints.items) : static_cast<const DevKeypoint*>(nullptr),
      detail::count_of(right_keypoints, right_capacity), dev<std::uint8_t>(right_descriptors), launch,
      dev<std::int32_t>(matches), dev<std::int32_t>(sads), dev<std::uint32_t>(histogram));
}

// §3.10: a warp per query scanning the keypoint list.
void CudaBackend::projection_match(ConstDeviceList keypoints, const Buffer& keypoint_descriptors,
                                   const Buffer& queries, const Buffer& query_descriptors, int num_queries,
                                   const std::vector<std::int32_t>& scales_q16, Buffer& results) {
  detail::check_count_offset("projection_match", keypoints);
  // Never past the end of a query-side buffer (the cpu backend trusts num_queries).
  const std::int64_t n = checks::usable_queries(num_queries, queries, query_descriptors, results);
  if (n == 0) return;
  const int capacity = detail::usable_capacity(
      keypoints, {{keypoints.items, sizeof(Keypoint)}, {&keypoint_descriptors, sizeof(Descriptor)}});
  // A keypoint's level is a uint8: scales past 256 entries name no level.
  ProjectionScales scales{};
  scales.count = static_cast<int>(std::min<std::size_t>(scales_q16.size(), 256));
  std::copy_n(scales_q16.begin(), scales.count, scales.v);
  activate();
  enqueue<&launch_projection_match>(
      "projection_match", capacity > 0 ? dev<DevKeypoint>(*keypoints.items) : static_cast<const DevKeypoint*>(nullptr),
      detail::count_of(keypoints, capacity), dev<std::uint8_t>(keypoint_descriptors), dev<std::uint8_t>(queries),
      dev<std::uint8_t>(query_descriptors), static_cast<int>(n), scales, dev<std::int32_t>(results));
}

}  // namespace porta::cuda
