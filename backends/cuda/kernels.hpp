// The boundary between the CUDA backend's host code (C++20, g++) and its kernels (.cu, nvcc): plain
// structs passed to kernels by value and one launcher per kernel contract. Deliberately C++17 and
// free of engine headers, so that the .cu files build with older nvcc (Jetson's CUDA 11.4) and
// compile quickly. Launchers enqueue on `stream` and return the launch status; they never wait.
//
// Launchers are pure functions of their arguments (no host state), so the backend may defer them,
// replay them in a CUDA graph, and key that graph by the bytes of the arguments: every argument
// struct here therefore has no implicit padding (explicit `pad` members instead, zero), which the
// host checks with std::has_unique_object_representations.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>

namespace porta::cuda {

inline constexpr int kMaxLevels = 12;

/// A plane of a buffer (layout.hpp Plane).
struct DevPlane {
  std::int64_t offset_bytes;
  int width;
  int height;
  int pitch;
  int pad;
};

/// A keypoint (keypoint.hpp Keypoint), 8 bytes.
struct DevKeypoint {
  std::uint16_t x;
  std::uint16_t y;
  std::uint16_t response;
  std::uint8_t level;
  std::uint8_t angle_bin;
};
static_assert(sizeof(DevKeypoint) == 8, "DevKeypoint must mirror porta::Keypoint");

/// The length of a device list: the uint32 at `bytes` (any alignment), at most `capacity` (the
/// slots the kernel may touch, already clamped to the buffers by the host).
struct DevCount {
  const std::uint8_t* bytes;
  int capacity;
  int pad;  ///< 0 (no implicit padding: see the top of this file)
};

/// Levels of a pyramid; blocks of a launch over all of them are assigned level by level:
/// level n owns blocks [first_block[n], first_block[n + 1]) in tiles of tiles_x per row.
struct DevTiledLevels {
  DevPlane level[kMaxLevels];
  int first_block[kMaxLevels + 1];
  int tiles_x[kMaxLevels];
  int count;
};

// ---- image_kernels.cu ----------------------------------------------------------------------------

inline constexpr int kTileW = 32;  ///< tile of the per-pixel kernels: 32 x 8 pixels, 256 threads
inline constexpr int kTileH = 8;
inline constexpr int kTileThreads = kTileW * kTileH;

/// The 7 blur taps (sum 256).
struct DevBlurTaps {
  std::int32_t t[7];
};

cudaError_t launch_rectify(const std::uint8_t* src, DevPlane src_plane, const std::int32_t* map,
                           std::uint8_t* dst, DevPlane dst_plane, cudaStream_t stream);
/// One level from the one above; `table` points at the level's columns/rows of the resize table.
cudaError_t launch_resize_level(std::uint8_t* pyramid, DevPlane above, DevPlane level,
                                const std::int32_t* table, cudaStream_t stream);
/// All levels in one launch (tiles of kTileW x kTileH).
cudaError_t launch_blur(const std::uint8_t* src, std::uint8_t* dst, const DevTiledLevels& levels,
                        DevBlurTaps taps, cudaStream_t stream);

// ---- detect_kernels.cu ---------------------------------------------------------------------------

struct FastLaunch {
  DevTiledLevels src;  ///< pyramid levels and the tiling of the launch
  DevPlane dst[kMaxLevels];
  int dx[16];
  int dy[16];
  int threshold;
  int edge;
};
cudaError_t launch_fast_crf(const std::uint8_t* pyramid, const std::uint8_t* lut, std::uint8_t* responses,
                            const FastLaunch& p, cudaStream_t stream);

inline constexpr int kCullBlock = 128;  ///< threads of a culling block (TEWA packs cells into it)

/// How the culling launch splits the work (CullLaunch::variant); all give the same bytes.
inline constexpr int kCullMlptTewa = 0;   ///< MLPT threads, TEWA: several cells per 128-thread block
inline constexpr int kCullMlptBlock = 1;  ///< MLPT threads, one cell per 128-thread block
inline constexpr int kCullLog2Block = 2;  ///< one cell per block of block_threads threads, each
                                          ///< thread strides over the cell's pixels, then a
                                          ///< shared-memory log2 tree reduction

/// Culling of one level: MLPT (each thread scans up to band_rows rows of lanes_x-strided columns
/// of one cell) and TEWA (cells_per_block cells of cell_threads threads share a block).
struct CullLevel {
  DevPlane plane;
  int cell_w, cell_h, cols, rows, first_cell;
  int lanes_x;          ///< threads across a cell, <= kCullBlock
  int band_rows;        ///< rows per thread
  int cell_threads;     ///< lanes_x * bands
  int cells_per_block;  ///< kCullBlock / cell_threads
  int pad;              ///< 0
};
struct CullLaunch {
  CullLevel level[kMaxLevels];
  int first_block[kMaxLevels + 1];
  int count;
  int variant;        ///< kCullMlptTewa, kCullMlptBlock or kCullLog2Block
  int block_threads;  ///< kCullLog2Block: threads per block, a power of two in [32, 1024]
};
cudaError_t launch_cull_cells(const std::uint8_t* responses, const CullLaunch& p, DevKeypoint* cells,
                              cudaStream_t stream);

struct PfaLaunch {
  std::int32_t scales_q16[kMaxLevels];
  int num_scales;
  int width0;
  int height0;
  int reach;  ///< window / 2
  int total_cells;
};
/// Three launches; `sum_map` and `level_map` (level-0 sized uint32) must be zero and are zero again
/// afterwards; `rejected` holds total_cells bytes.
cudaError_t launch_pfa_filter(DevKeypoint* cells, const PfaLaunch& p, std::uint32_t* sum_map,
                              std::uint32_t* level_map, std::uint8_t* rejected, cudaStream_t stream);

inline constexpr int kCompactCellsPerBlock = 1024;
/// `block_scratch` holds one uint32 per kCompactCellsPerBlock cells; `count` the list's uint32.
cudaError_t launch_compact(const DevKeypoint* cells, int total_cells, DevKeypoint* items,
                           std::uint32_t capacity, std::uint8_t* count, std::uint32_t* block_scratch,
                           cudaStream_t stream);

// ---- describe_kernels.cu -------------------------------------------------------------------------

struct DevLevels {
  DevPlane level[kMaxLevels];
  int count;
  int pad;  ///< 0
};
/// umax[dy] of the orientation patch (build_orientation_umax()).
struct DevUmax {
  int v[16];
};
cudaError_t launch_orient(const std::uint8_t* pyramid, const DevLevels& layout, DevKeypoint* keypoints,
                          DevCount count, DevUmax umax, const std::int32_t* boundaries, int bins,
                          cudaStream_t stream);
cudaError_t launch_orb_describe(const std::uint8_t* blurred, const DevLevels& layout,
                                const DevKeypoint* keypoints, DevCount count, const std::int8_t* pattern,
                                int bins, std::uint8_t* descriptors, cudaStream_t stream);

// ---- match_kernels.cu ----------------------------------------------------------------------------

/// Fine bins (one per SAD value), coarse bins of 256 values, then the median, as uint32s.
inline constexpr int kSadValues = 61711;
inline constexpr int kSadBlocks = (kSadValues + 255) / 256;
inline constexpr int kHistogramWords = kSadValues + kSadBlocks + 1;

struct StereoLaunch {
  DevLevels layout;
  std::int32_t scales_q16[kMaxLevels];
  std::int32_t row_radius_q8[kMaxLevels];
  int min_disparity_q8;
  int max_disparity_q8;
  int max_hamming;
  int pad;  ///< 0
};
/// Candidates, then median and rejection; `sads` holds one int32 per left slot, `histogram`
/// kHistogramWords uint32 (cleared here).
cudaError_t launch_stereo_match(const std::uint8_t* left_pyramid, const std::uint8_t* right_pyramid,
                                const DevKeypoint* left, DevCount left_count,
                                const std::uint8_t* left_descriptors, const DevKeypoint* right,
                                DevCount right_count, const std::uint8_t* right_descriptors,
                                const StereoLaunch& p, std::int32_t* matches, std::int32_t* sads,
                                std::uint32_t* histogram, cudaStream_t stream);

/// Scales of every level a uint8 can name.
struct ProjectionScales {
  std::int32_t v[256];
  int count;
};
cudaError_t launch_projection_match(const DevKeypoint* keypoints, DevCount count,
                                    const std::uint8_t* keypoint_descriptors, const std::uint8_t* queries,
                                    const std::uint8_t* query_descriptors, int num_queries,
                                    const ProjectionScales& scales, std::int32_t* results,
                                    cudaStream_t stream);

/// A trivial launch-free query that fails with cudaErrorNoKernelImageForDevice (or similar) when
/// this build holds no code the current device can run.
cudaError_t probe_kernel_image();

}  // namespace porta::cuda
