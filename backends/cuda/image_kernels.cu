// Image kernels of the CUDA backend: rectification, pyramid levels and the descriptor blur
// (DESIGN.md §3.1, §3.2, §3.7). Integer arithmetic only; the bytes are those of the cpu backend
// (backends/cpu/image_kernels.cpp).
#include <cstdint>

#include "cuda/device_common.cuh"

namespace porta::cuda {

namespace {

// §3.1: one thread per destination pixel; bilinear sample at the Q5 map position (xq, yq) with
// 5-bit weights, (sum w * p + 512) >> 10; taps outside the source read 0.
__global__ void __launch_bounds__(kTileThreads)
    rectify_kernel(const std::uint8_t* src, DevPlane sp, const std::int32_t* __restrict__ map,
                   std::uint8_t* dst, DevPlane dp) {
  const int x = static_cast<int>(blockIdx.x) * kTileW + static_cast<int>(threadIdx.x);
  const int y = static_cast<int>(blockIdx.y) * kTileH + static_cast<int>(threadIdx.y);
  if (x >= dp.width || y >= dp.height) return;
  const int2 q = __ldg(reinterpret_cast<const int2*>(map) + (static_cast<long long>(y) * dp.width + x));
  // Floor division by 32 without relying on >> of negative values: xq - (xq & 31) is a multiple of 32.
  const std::uint32_t fx = static_cast<std::uint32_t>(q.x & 31);
  const std::uint32_t fy = static_cast<std::uint32_t>(q.y & 31);
  const int x0 = (q.x - static_cast<int>(fx)) / 32;
  const int y0 = (q.y - static_cast<int>(fy)) / 32;
  const std::uint8_t* s = src + sp.offset_bytes;
  std::uint32_t p00 = 0, p10 = 0, p01 = 0, p11 = 0;
  const bool in_x0 = x0 >= 0 && x0 < sp.width;
  const bool in_x1 = x0 + 1 >= 0 && x0 + 1 < sp.width;
  if (y0 >= 0 && y0 < sp.height) {
    const std::uint8_t* row = s + static_cast<long long>(y0) * sp.pitch;
    if (in_x0) p00 = row[x0];
    if (in_x1) p10 = row[x0 + 1];
  }
  if (y0 + 1 >= 0 && y0 + 1 < sp.height) {
    const std::uint8_t* row = s + static_cast<long long>(y0 + 1) * sp.pitch;
    if (in_x0) p01 = row[x0];
    if (in_x1) p11 = row[x0 + 1];
  }
  const std::uint32_t sum =
      (32 - fx) * (32 - fy) * p00 + fx * (32 - fy) * p10 + (32 - fx) * fy * p01 + fx * fy * p11;
  dst[dp.offset_bytes + static_cast<long long>(y) * dp.pitch + x] =
      static_cast<std::uint8_t>((sum + 512) >> 10);
}

// §3.2: one thread per pixel of a level, from the level above: table = cols.src0 (W), cols.w1
// (W), rows.src0 (H), rows.w1 (H); (wy0 (wx0 p00 + wx1 p10) + wy1 (wx0 p01 + wx1 p11) + 2^21) >> 22.
__global__ void __launch_bounds__(kTileThreads)
    resize_level_kernel(std::uint8_t* pyramid, DevPlane above, DevPlane level,
                        const std::int32_t* __restrict__ table) {
  const int j = static_cast<int>(blockIdx.x) * kTileW + static_cast<int>(threadIdx.x);
  const int i = static_cast<int>(blockIdx.y) * kTileH + static_cast<int>(threadIdx.y);
  if (j >= level.width || i >= level.height) return;
  const std::int32_t* col_src0 = table;
  const std::int32_t* col_w1 = col_src0 + level.width;
  const std::int32_t* row_src0 = col_w1 + level.width;
  const std::int32_t* row_w1 = row_src0 + level.height;
  const int y0 = __ldg(row_src0 + i);
  const int y1 = min(y0 + 1, above.height - 1);
  const std::uint32_t wy1 = static_cast<std::uint32_t>(__ldg(row_w1 + i)), wy0 = 2048 - wy1;
  const int x0 = __ldg(col_src0 + j);
  const int x1 = min(x0 + 1, above.width - 1);
  const std::uint32_t wx1 = static_cast<std::uint32_t>(__ldg(col_w1 + j)), wx0 = 2048 - wx1;
  const std::uint8_t* top = pyramid + above.offset_bytes + static_cast<long long>(y0) * above.pitch;
  const std::uint8_t* bottom = pyramid + above.offset_bytes + static_cast<long long>(y1) * above.pitch;
  // At most 2048 * (2048 * 255) + 2^21 < 2^31: no overflow in 32 bits.
  const std::uint32_t sum =
      wy0 * (wx0 * top[x0] + wx1 * top[x1]) + wy1 * (wx0 * bottom[x0] + wx1 * bottom[x1]);
  pyramid[level.offset_bytes + static_cast<long long>(i) * level.pitch + j] =
      static_cast<std::uint8_t>((sum + (1u << 21)) >> 22);
}

struct BlurTaps {
  std::int32_t t[7];
};

constexpr int kHalo = 3;
constexpr int kInW = kTileW + 2 * kHalo;  // 38 source columns per tile
constexpr int kInH = kTileH + 2 * kHalo;  // 14 source rows per tile

// §3.7: one block per 32 x 8 output tile of any level (all levels in one launch). The source tile
// with its reflect-101 halo goes to shared memory, then the horizontal pass h = sum t_k p (kept
// unrounded, as the cpu's uint16) for the 14 rows the tile needs, then the vertical pass
// (sum t_k h + 2^15) >> 16. Tile row r holds source row reflect101(y0 - 3 + r), so output row
// y0 + ty reads tile rows ty .. ty + 6, exactly the cpu's reflect101(y + k - 3).
__global__ void __launch_bounds__(kTileThreads)
    blur_kernel(const std::uint8_t* __restrict__ src, std::uint8_t* __restrict__ dst, DevTiledLevels levels,
                BlurTaps taps) {
  __shared__ std::uint8_t in[kInH][kInW + 2];
  __shared__ std::uint32_t h[kInH][kTileW + 1];
  const int n = level_of_block(levels.first_block, levels.count, static_cast<int>(blockIdx.x));
  if (n < 0) return;
  const DevPlane p = levels.level[n];
  const int tile = static_cast<int>(blockIdx.x) - levels.first_block[n];
  const int x0 = (tile % levels.tiles_x[n]) * kTileW;
  const int y0 = (tile / levels.tiles_x[n]) * kTileH;
  const int tid = static_cast<int>(threadIdx.y) * kTileW + static_cast<int>(threadIdx.x);
  const std::uint8_t* level = src + p.offset_bytes;

  for (int k = tid; k < kInH * kInW; k += kTileThreads) {
    const int r = k / kInW, c = k - r * kInW;
    const int sy = contract::reflect101(y0 - kHalo + r, p.height);
    const int sx = contract::reflect101(x0 - kHalo + c, p.width);
    in[r][c] = level[static_cast<long long>(sy) * p.pitch + sx];
  }
  __syncthreads();
  for (int k = tid; k < kInH * kTileW; k += kTileThreads) {
    const int r = k / kTileW, c = k - r * kTileW;
    std::uint32_t sum = 0;
#pragma unroll
    for (int t = 0; t < 7; ++t) sum += static_cast<std::uint32_t>(taps.t[t]) * in[r][c + t];
    h[r][c] = sum;
  }
  __syncthreads();
  const int x = x0 + static_cast<int>(threadIdx.x), y = y0 + static_cast<int>(threadIdx.y);
  if (x >= p.width || y >= p.height) return;
  std::uint32_t sum = 0;  // at most 256 * 65280 + 2^15 < 2^24
#pragma unroll
  for (int t = 0; t < 7; ++t) sum += static_cast<std::uint32_t>(taps.t[t]) * h[threadIdx.y + t][threadIdx.x];
  dst[p.offset_bytes + static_cast<long long>(y) * p.pitch + x] =
      static_cast<std::uint8_t>((sum + (1u << 15)) >> 16);
}

}  // namespace

cudaError_t launch_rectify(const std::uint8_t* src, DevPlane src_plane, const std::int32_t* map,
                           std::uint8_t* dst, DevPlane dst_plane, cudaStream_t stream) {
  const dim3 grid(blocks_for(dst_plane.width, kTileW), blocks_for(dst_plane.height, kTileH));
  rectify_kernel<<<grid, dim3(kTileW, kTileH), 0, stream>>>(src, src_plane, map, dst, dst_plane);
  return cudaGetLastError();
}

cudaError_t launch_resize_level(std::uint8_t* pyramid, DevPlane above, DevPlane level,
                                const std::int32_t* table, cudaStream_t stream) {
  const dim3 grid(blocks_for(level.width, kTileW), blocks_for(level.height, kTileH));
  resize_level_kernel<<<grid, dim3(kTileW, kTileH), 0, stream>>>(pyramid, above, level, table);
  return cudaGetLastError();
}

cudaError_t launch_blur(const std::uint8_t* src, std::uint8_t* dst, const DevTiledLevels& levels,
                        DevBlurTaps taps, cudaStream_t stream) {
  const int blocks = levels.first_block[levels.count];
  if (blocks <= 0) return cudaSuccess;
  BlurTaps t{};
  for (int k = 0; k < 7; ++k) t.t[k] = taps.t[k];
  blur_kernel<<<static_cast<unsigned>(blocks), dim3(kTileW, kTileH), 0, stream>>>(src, dst, levels, t);
  return cudaGetLastError();
}

}  // namespace porta::cuda
