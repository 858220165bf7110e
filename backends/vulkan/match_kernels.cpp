// Matching kernels of the Vulkan backend: stereo matching and projection matching (DESIGN.md
// §3.9, §3.10); shaders stereo_match_candidates.comp, stereo_match_finish.comp and
// projection_match.comp. Every kernel launches over a list's capacity and reads the list's length
// on the device; no call waits for the host. The candidate searches are full scans of the other
// list, split over a workgroup and reduced through shared memory with explicit tie rules, which
// makes them equal to the cpu's row-bucketed searches (backends/cpu/match_kernels.cpp).
#include <algorithm>
#include <cstdint>
#include <string>

#include "vulkan/vk_runtime.hpp"
#include "vulkan/vk_types.hpp"
#include "vulkan/vulkan_backend.hpp"

namespace porta::vulkan {

namespace {

// Must match stereo_common.glsl: STEREO_SAD_VALUES fine bins, STEREO_SAD_BLOCKS coarse bins, the median.
constexpr std::size_t kSadValues = 61711;  // a centred 11x11 SAD is at most 121 * 510
constexpr std::size_t kSadBlocks = (kSadValues + 255) / 256;
constexpr std::size_t kHistogramBytes = (kSadValues + kSadBlocks + 1) * sizeof(std::uint32_t);

struct StereoCandidatesParams {  // stereo_match_candidates.comp (parameter buffer)
  GlslLevels layout;
  std::int32_t scales[kMaxLevels];
  std::int32_t row_radius[kMaxLevels];
  std::int32_t left_capacity;
  std::uint32_t left_count_offset;
  std::int32_t right_capacity;
  std::uint32_t right_count_offset;
  std::int32_t min_disparity, max_disparity, max_hamming, pad;
};
struct StereoFinishParams {  // stereo_match_finish.comp (push constants)
  std::int32_t left_capacity;
  std::uint32_t left_count_offset;
};
struct ProjectionParams {  // projection_match.comp (push constants)
  std::int32_t capacity;
  std::uint32_t count_offset;
  std::int32_t num_queries, num_scales;
  std::int32_t scales[kMaxLevels];
};
static_assert(sizeof(StereoCandidatesParams) == 208 + 96 + 32 &&
              sizeof(StereoCandidatesParams) <= kMaxParamsBytes);
static_assert(sizeof(StereoFinishParams) <= kMaxPushBytes && sizeof(ProjectionParams) == 64);

[[noreturn]] void fail(const char* call, const std::string& what) { checks::fail(kBackend, call, what); }

/// The first `n` values of a per-level table (the rest zero).
void first_levels(const std::vector<std::int32_t>& v, std::size_t n, std::int32_t (&out)[kMaxLevels]) {
  for (std::size_t i = 0; i < std::min<std::size_t>({n, v.size(), static_cast<std::size_t>(kMaxLevels)}); ++i)
    out[i] = v[i];
}

}  // namespace

// §3.9 in two dispatches: candidates (steps a-e, one workgroup per left slot; each accepted SAD
// counted in a histogram) and finish (one workgroup: the median from the histogram, then the
// outlier cut over all slots).
void VulkanBackend::stereo_match(const Buffer& left_pyramid, const Buffer& right_pyramid,
                                 const PyramidLayout& layout, ConstDeviceList left_keypoints,
                                 const Buffer& left_descriptors, ConstDeviceList right_keypoints,
                                 const Buffer& right_descriptors, const StereoParams& params,
                                 Buffer& matches) {
  const auto levels = static_cast<std::size_t>(layout.num_levels());
  checks::check_stereo_tables(kBackend, layout, params);
  if (layout.element_bytes != 1) fail("stereo_match", "the pyramids must hold 8-bit pixels");
  StereoCandidatesParams p{};
  p.layout = to_glsl(layout, "stereo_match");  // refuses more than 12 levels
  for (const Plane& plane : layout.levels) {
    require_plane_inside(left_pyramid, plane, 1, "stereo_match", "left pyramid level");
    require_plane_inside(right_pyramid, plane, 1, "stereo_match", "right pyramid level");
  }
  const int left_capacity = usable_capacity(left_keypoints,
                                            {{left_keypoints.items, sizeof(Keypoint)},
                                             {&left_descriptors, sizeof(Descriptor)},
                                             {&matches, sizeof(StereoMatch)}},
                                            "stereo_match");
  const int right_capacity = usable_capacity(
      right_keypoints, {{right_keypoints.items, sizeof(Keypoint)}, {&right_descriptors, sizeof(Descriptor)}},
      "stereo_match");
  if (left_capacity == 0) return;
  // An empty right list still needs buffers to bind: the left list's, read as 0 slots.
  const bool right_empty = right_capacity == 0;
  const Buffer* right_items = right_empty ? left_keypoints.items : right_keypoints.items;
  const Buffer* right_count = right_empty ? left_keypoints.count : right_keypoints.count;

  first_levels(params.scales_q16, levels, p.scales);
  first_levels(params.row_radius_q8, levels, p.row_radius);
  p.left_capacity = left_capacity;
  p.left_count_offset = static_cast<std::uint32_t>(left_keypoints.count_offset_bytes);
  p.right_capacity = right_capacity;
  p.right_count_offset = static_cast<std::uint32_t>(right_empty ? left_keypoints.count_offset_bytes
                                                                : right_keypoints.count_offset_bytes);
  p.min_disparity = params.min_disparity_q8;
  p.max_disparity = params.max_disparity_q8;
  p.max_hamming = params.max_hamming;

  Buffer& sads = scratch("stereo_match.sads", static_cast<std::size_t>(left_capacity) * sizeof(std::int32_t));
  Buffer& histogram = scratch("stereo_match.histogram", kHistogramBytes);
  fill(histogram, 0, kHistogramBytes, 0);
  // GPUs: a workgroup of 64 per left slot; CPU devices: one invocation per slot (the same bytes).
  const bool groups = work_groups();
  rt().dispatch(groups ? "stereo_match_candidates" : "stereo_match_candidates_per_item",
                {&left_pyramid, &right_pyramid, left_keypoints.items, left_keypoints.count, &left_descriptors,
                 right_items, right_count, &right_descriptors, &matches, &sads, &histogram},
                p,
                groups ? Work::groups(static_cast<std::uint64_t>(left_capacity))
                       : Work::items(static_cast<std::uint64_t>(left_capacity)));
  const StereoFinishParams f{left_capacity, p.left_count_offset};
  rt().dispatch("stereo_match_finish", {left_keypoints.count, &sads, &histogram, &matches}, f,
                Work::groups(1));
}

// §3.10: one workgroup per query, a full scan of the keypoint list.
void VulkanBackend::projection_match(ConstDeviceList keypoints, const Buffer& keypoint_descriptors,
                                     const Buffer& queries, const Buffer& query_descriptors, int num_queries,
                                     const std::vector<std::int32_t>& scales_q16, Buffer& results) {
  const int capacity = usable_capacity(
      keypoints, {{keypoints.items, sizeof(Keypoint)}, {&keypoint_descriptors, sizeof(Descriptor)}},
      "projection_match");
  // Never past the end of a query-side buffer (the cpu backend trusts num_queries).
  const std::int64_t n = checks::usable_queries(num_queries, queries, query_descriptors, results);
  if (n == 0) return;
  // A keypoint's level is a uint8: scales past 256 entries name no level.
  const std::size_t num_scales = std::min<std::size_t>(scales_q16.size(), 256);
  // Scales of levels >= 12 (no pyramid has them, but the contract allows such a table) go to the
  // device through a scratch buffer; only then is there an upload.
  Buffer* more = &scratch("projection_match.more_scales", sizeof(std::int32_t));
  if (num_scales > static_cast<std::size_t>(kMaxLevels)) {
    const std::size_t extra = num_scales - static_cast<std::size_t>(kMaxLevels);
    more = &scratch("projection_match.more_scales", extra * sizeof(std::int32_t));
    upload(*more, 0, scales_q16.data() + kMaxLevels, extra * sizeof(std::int32_t));
  }
  ProjectionParams p{};
  p.capacity = capacity;
  const bool empty = capacity == 0;
  p.count_offset = empty ? 0u : static_cast<std::uint32_t>(keypoints.count_offset_bytes);
  p.num_queries = static_cast<std::int32_t>(n);
  p.num_scales = static_cast<std::int32_t>(num_scales);
  first_levels(scales_q16, num_scales, p.scales);
  // An empty list still needs buffers to bind (read as 0 slots).
  const Buffer* items = empty ? &keypoint_descriptors : keypoints.items;
  const Buffer* count = empty ? more : keypoints.count;
  rt().dispatch("projection_match",
                {items, count, &keypoint_descriptors, &queries, &query_descriptors, more, &results}, p,
                Work::groups(static_cast<std::uint64_t>(n)));
}

}  // namespace porta::vulkan
