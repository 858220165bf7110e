// Host-side argument checks shared by every backend: what a kernel indexes with is checked before
// it runs, so that a bad argument is a BackendError naming the backend, the kernel and the
// argument ("<backend>: <kernel>: ...") instead of corrupted memory or a device fault. Plain C++;
// no device API.
#pragma once

#include <array>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "porta/backend.hpp"
#include "porta/layout.hpp"

namespace porta::checks {

/// Throws BackendError("<backend>: <kernel>: <what>").
[[noreturn]] void fail(std::string_view backend, std::string_view kernel, const std::string& what);

/// What a backend's kernels can address beyond "inside the buffer": whether a plane's offset must
/// be a multiple of its element size, and the largest offset and end (in bytes) they can index.
struct PlaneLimits {
  bool aligned = false;
  std::int64_t max_offset = std::numeric_limits<std::int64_t>::max();
  std::int64_t max_end = std::numeric_limits<std::int64_t>::max();
};

/// A non-empty `plane` of `element_bytes` elements must lie inside `buffer` (and within `limits`).
void check_plane(std::string_view backend, std::string_view kernel, std::string_view what, const Buffer& buffer,
                 const Plane& plane, int element_bytes, const PlaneLimits& limits = {});

/// `buffer` must hold at least `bytes` bytes.
void check_bytes(std::string_view backend, std::string_view kernel, std::string_view what, const Buffer& buffer,
                 std::int64_t bytes);

/// `a` and `b` must have the same number of levels, of the same sizes.
void check_same_level_sizes(std::string_view backend, std::string_view kernel, const PyramidLayout& a,
                            const PyramidLayout& b);

/// build_pyramid's arguments: one resize table offset per level below the first, every level inside
/// `pyramid`, and each level's table inside `resize_table`; a negative table offset is refused
/// (before its size is checked) where `reject_negative_offsets`.
void check_pyramid(std::string_view backend, const Buffer& pyramid, const PyramidLayout& layout,
                   const Buffer& resize_table, const std::vector<std::int32_t>& level_offset,
                   bool reject_negative_offsets, const PlaneLimits& limits = {});

/// rectify's arguments: both planes inside their buffers, a map of (x, y) int32 pairs for every
/// destination pixel.
void check_rectify(std::string_view backend, const Buffer& src, const Plane& src_plane, const Buffer& map,
                   const Buffer& dst, const Plane& dst_plane, const PlaneLimits& limits = {});

/// blur's arguments: taps non-negative and summing to 256 (build_blur_taps()), every level inside
/// both `pyramid` and `blurred`.
void check_blur(std::string_view backend, const Buffer& pyramid, const PyramidLayout& layout,
                const Buffer& blurred, const std::array<std::int32_t, 7>& taps, const PlaneLimits& limits = {});

/// orient's tables: 1 to 256 bins (angle_bin is a uint8), a boundary table of `bins` (x, y) int32
/// pairs, umax entries inside [0, kOrientationRadius].
void check_orient_tables(std::string_view backend, const std::array<int, 16>& umax, const Buffer& boundaries,
                         int bins);

/// The pyramid of `layout` must hold 8-bit pixels.
void check_8bit_pixels(std::string_view backend, std::string_view kernel, const PyramidLayout& layout);

/// orb_describe's number of angle bins: as many whole bins of kOrbPairs (x, y) int8 pairs as
/// `pattern` holds, at most 256 (angle_bin can name no more); refuses a table without one.
int orb_pattern_bins(std::string_view backend, const Buffer& pattern);

/// stereo_match's per-level tables: scales_q16 and row_radius_q8 hold one entry per level.
void check_stereo_tables(std::string_view backend, const PyramidLayout& layout, const StereoParams& params);

/// projection_match's queries a kernel may touch: num_queries (0 when negative), but never more
/// than `queries`, `query_descriptors` or `results` hold (the cpu backend trusts num_queries).
std::int64_t usable_queries(int num_queries, const Buffer& queries, const Buffer& query_descriptors,
                            const Buffer& results);

/// fast_crf's border: at least 3, the radius of the FAST circle.
void check_fast_edge(std::string_view backend, const FastParams& params);

/// fast_crf's arguments: the pyramid and response layouts of the same level sizes, the border (as
/// check_fast_edge), the 65 536-byte FAST table, every level inside its buffer (within `limits`).
void check_fast(std::string_view backend, const Buffer& pyramid, const PyramidLayout& layout, const Buffer& lut,
                const Buffer& responses, const PyramidLayout& response_layout, const FastParams& params,
                const PlaneLimits& limits = {});

/// cull_cells' arguments: a cell grid per response level, none with a negative size or start (and,
/// where `max_cell_pixels` > 0, every cell non-empty and of at most that many pixels), every
/// response level inside `responses` (within `limits`), the cells of every grid inside `cells`.
/// Returns the end of the last grid: the cells culling writes.
std::int64_t check_cull(std::string_view backend, const Buffer& responses, const PyramidLayout& response_layout,
                        const CellLayout& cell_layout, const Buffer& cells, std::int64_t max_cell_pixels,
                        const PlaneLimits& limits = {});

/// PFA's parameters as its kernels take them (DESIGN.md §3.5): the scales of the first
/// num_scales levels, the cells, the level-0 size and the window's reach (q / 2).
struct PfaSetup {
  std::array<std::int32_t, 12> scales{};
  std::int32_t total_cells = 0, num_scales = 0, width0 = 0, height0 = 0, reach = 0;
};

/// pfa_filter's arguments: a non-empty level-0 size of at most `max_pixels0` pixels, a scale for
/// every cell level, the cell array inside `cells`. Returns the kernels' parameters (total_cells
/// 0: nothing to do, the cells unchecked).
PfaSetup check_pfa(std::string_view backend, const Buffer& cells, const CellLayout& cell_layout,
                   const PfaParams& params, std::int64_t max_pixels0);

/// compact_keypoints' arguments: a count buffer holding the count at a non-negative offset, a cell
/// array of max(total_cells, 0) keypoints. Returns the records that may be written: the capacity,
/// but never past the end of the items buffer (0 without one).
std::int64_t compact_capacity(std::string_view backend, const Buffer& cells, int total_cells,
                              const DeviceList& out);

/// orb_describe's slots on a device: `capacity` (the list's usable capacity), but no more than
/// `descriptors` holds. Only when the buffer is smaller is the count read on the host (one
/// round-trip through `device`), to refuse a list that does not fit as the cpu backend does.
int descriptor_capacity(Backend& device, std::string_view backend, const ConstDeviceList& keypoints, int capacity,
                        const Buffer& descriptors);

/// A device list's count (a uint32 at count_offset_bytes) must lie inside its buffer, at an offset
/// of at most `max_offset`; no check for a list without a count buffer.
void check_count_offset(std::string_view backend, std::string_view kernel, const ConstDeviceList& list,
                        std::int64_t max_offset = std::numeric_limits<std::int64_t>::max());

/// The list slots a kernel launched over a device list's capacity may touch: the capacity, but
/// never more records than each of `buffers` (with its record size) holds. The cpu backend reads
/// only `count` records, so a capacity larger than a buffer is no error as long as the count fits;
/// the device must not read past the end. 0 for a list without items or count.
int usable_capacity(const ConstDeviceList& list,
                    std::initializer_list<std::pair<const Buffer*, std::size_t>> buffers);

/// The integer in environment variable `variable`, or `fallback` when it is unset or empty; a
/// BackendError ("<backend>: VARIABLE must be <what> from lo to hi, got '...'") when it is not an
/// integer in [lo, hi].
int env_int(std::string_view backend, const char* variable, int lo, int hi, int fallback, std::string_view what);

/// The switch `variable` of the environment: true for "on", false for "off", `fallback` when it
/// is unset or empty; anything else fails ("<backend>: <variable> must be on or off, got '...'").
bool env_switch(std::string_view backend, const char* variable, bool fallback);

/// Tiles of tile_w x tile_h pixels over every level of a pyramid, numbered level by level: the
/// launch geometry of GPU kernels that run all levels in one dispatch, one workgroup per tile.
/// Level n owns tiles [first[n], first[n + 1]); `across[n]` tiles make one of its rows. Empty
/// levels own none.
struct LevelTiles {
  std::vector<std::int32_t> first;   ///< num_levels + 1 entries; first.back() is the total
  std::vector<std::int32_t> across;  ///< num_levels entries
};

/// The tiles of `layout`; fails ("<backend>: <kernel>: ...") when they number more than 2^31 - 1.
LevelTiles tile_levels(std::string_view backend, std::string_view kernel, const PyramidLayout& layout, int tile_w,
                       int tile_h);

/// For fused pyramid kernels: one dispatch builds levels 1..m, one workgroup per tile_w x tile_h
/// tile of those levels, each computing from level 0, in on-chip memory, the regions of levels
/// 1..n-1 that its level-n tile reads. Returns the largest such m (at most num_levels - 1) for
/// which every region, its rows padded to 4 bytes, fits in `capacity_bytes`, with the resize
/// tables build_resize_tables makes for the layout's level sizes (the contract's tables, whose
/// source indices never decrease). 0 for one level, or when level 1 is empty; levels after an
/// empty one are not fused.
int fused_pyramid_levels(const PyramidLayout& layout, int tile_w, int tile_h, std::int64_t capacity_bytes);

/// fused_pyramid_levels for one kernel's tile and capacity, computed once per layout (its levels'
/// sizes): a backend's member.
class FusedPyramidLevels {
 public:
  FusedPyramidLevels(int tile_w, int tile_h, std::int64_t capacity_bytes)
      : tile_w_(tile_w), tile_h_(tile_h), capacity_(capacity_bytes) {}
  int operator()(const PyramidLayout& layout);

 private:
  int tile_w_, tile_h_;
  std::int64_t capacity_;
  std::map<std::vector<std::int32_t>, int> known_;  // key: the levels' widths and heights
};

/// The work split of the fused FAST and culling kernels (vulkan fast_cull.comp, opencl
/// fast_cull_group): workgroups of `group_size` invocations (a power of two), each level's cells
/// `1 << shift[n]` invocations each, 256 / that many cells to a workgroup. For a grid of fewer
/// than kSmallGridPixels pixels, the power of two >= a quarter of the level's cell pixels (1 to
/// group_size): such an image leaves most of a GPU idle, and its cells' scans are its latency (at
/// 320x240 with one level a 32 x 32 cell takes a whole 256-wide workgroup; H100: 16.9 -> 9.1 us
/// against 64 invocations per cell). Above, 64 invocations per cell of every level, four cells
/// to a workgroup, as the 64-wide workgroup per cell this replaced: at 1242x375 with 8 levels
/// the GPU is full, and both 4 and 16 pixels per invocation were slower there on the H100 (NVIDIA
/// OpenCL 49.5 and 54.3 against 44.8-45.1 us per stereo frame; Vulkan 51.8 and 58.0 against
/// 52.1-52.2). With `pixels_per_invocation` > 0, every grid's cells take the power of two of
/// invocations >= their pixels over that (capped at group_size), whatever the grid's size (at
/// 752x480 with 8 levels on an H100, N = 1, 2, 4 and 8 took vulkan's kernel 23.1, 21.8, 20.6 and
/// 20.0 us against the rule's 18.6). Level n's cells start at workgroup first_group[n].
inline constexpr std::int64_t kSmallGridPixels = std::int64_t{1} << 18;
struct CellGroups {
  std::vector<std::int32_t> first_group;
  std::vector<std::int32_t> shift;
  std::int64_t groups = 0;  ///< workgroups in all
};
/// Throws BackendError when the workgroups would not fit in 32-bit signed indices.
CellGroups plan_cell_groups(std::string_view backend, std::string_view kernel, const CellLayout& cells,
                            int group_size, int pixels_per_invocation = 0);

}  // namespace porta::checks
