// Detection kernels of the CUDA backend: FAST corner response, per-cell culling (MLPT + TEWA),
// pyramidal feature aggregation and the canonical compaction (DESIGN.md §3.3-3.5). They
// reproduce the bytes of the cpu backend (backends/cpu/detect_kernels.cpp).
#include <cstddef>
#include <cstdint>

#include "cuda/device_common.cuh"

namespace porta::cuda {

namespace {

// §3.3: one thread per pixel of every level (all levels in one launch, 32 x 8 tiles). The 64 KB
// LUT stays in global memory and is read through the read-only data cache (__ldg): it does not
// fit in shared memory on the target GPUs (48 KB per block by default), and in flat regions all
// threads read entry 0, so the cache serves nearly every lookup.
__global__ void __launch_bounds__(kTileThreads)
    fast_crf_kernel(const std::uint8_t* __restrict__ pyramid, const std::uint8_t* __restrict__ lut,
                    std::uint8_t* __restrict__ responses, FastLaunch p) {
  const int n = level_of_block(p.src.first_block, p.src.count, static_cast<int>(blockIdx.x));
  if (n < 0) return;
  const DevPlane src = p.src.level[n];
  const int tile = static_cast<int>(blockIdx.x) - p.src.first_block[n];
  const int x = (tile % p.src.tiles_x[n]) * kTileW + static_cast<int>(threadIdx.x);
  const int y = (tile / p.src.tiles_x[n]) * kTileH + static_cast<int>(threadIdx.y);
  if (x >= src.width || y >= src.height) return;
  std::uint16_t response = 0;
  if (y >= p.edge && y < src.height - p.edge && x >= p.edge && x < src.width - p.edge) {
    const std::uint8_t* centre = pyramid + src.offset_bytes + static_cast<long long>(y) * src.pitch + x;
    const int c = __ldg(centre);
    unsigned bright = 0, dark = 0;
    int sum = 0;
#pragma unroll
    for (int i = 0; i < 16; ++i) {
      const int v = __ldg(centre + (static_cast<long long>(p.dy[i]) * src.pitch + p.dx[i]));
      // Two independent tests, as the contract (they only exclude each other for eps >= 0).
      if (v > c + p.threshold) bright |= 1u << i;
      if (v < c - p.threshold) dark |= 1u << i;
      sum += v > c ? v - c : c - v;
    }
    if (__ldg(lut + bright) | __ldg(lut + dark)) response = static_cast<std::uint16_t>(sum);
  }
  const DevPlane dst = p.dst[n];
  reinterpret_cast<std::uint16_t*>(responses + dst.offset_bytes)[static_cast<long long>(y) * dst.pitch + x] =
      response;
}

// The culling order as one integer: a larger key is a larger response, then a smaller row, then a
// smaller column; 0 is "no keypoint". A maximum over keys is the same whatever the order of the
// reduction, so MLPT and TEWA cannot change the result.
__device__ __forceinline__ unsigned long long cull_key(unsigned response, int y, int x) {
  return (static_cast<unsigned long long>(response) << 32) |
         (static_cast<unsigned long long>(0xFFFFu - static_cast<unsigned>(y)) << 16) |
         static_cast<unsigned long long>(0xFFFFu - static_cast<unsigned>(x));
}

// §3.4: per cell, the maximum response (ties to the smaller row, then column). All levels in one
// launch. TEWA: a block of 128 threads holds cells_per_block cells of a level, cell_threads
// threads each, so small cells do not leave most of a block idle. MLPT: thread (lane, band) of a
// cell scans the columns lane, lane + lanes_x, ... of the cell over band_rows rows (at most N_max
// unless the cell has more than 128 N_max pixels), then a segmented warp reduction and one
// shared-memory atomicMax per cell and warp combine the threads of a cell.
__global__ void __launch_bounds__(kCullBlock)
    cull_cells_kernel(const std::uint8_t* __restrict__ responses, CullLaunch p,
                      DevKeypoint* __restrict__ cells) {
  __shared__ unsigned long long best[kCullBlock];
  const int n = level_of_block(p.first_block, p.count, static_cast<int>(blockIdx.x));
  if (n < 0) return;  // uniform over the block
  const CullLevel& L = p.level[n];
  const int tid = static_cast<int>(threadIdx.x);
  const int slot = tid / L.cell_threads;
  const int local = tid - slot * L.cell_threads;
  const int first = (static_cast<int>(blockIdx.x) - p.first_block[n]) * L.cells_per_block;
  const int level_cells = L.cols * L.rows;
  const int cell = first + slot;
  const bool active = slot < L.cells_per_block && cell < level_cells;
  if (tid < L.cells_per_block) best[tid] = 0;
  __syncthreads();

  unsigned long long key = 0;
  if (active) {
    const int cell_y = cell / L.cols, cell_x = cell - cell_y * L.cols;
    const int x0 = cell_x * L.cell_w, x1 = min(x0 + L.cell_w, L.plane.width);
    const int cy0 = cell_y * L.cell_h, cy1 = min(cy0 + L.cell_h, L.plane.height);
    const int lane_x = local % L.lanes_x, band = local / L.lanes_x;
    const int y0 = cy0 + band * L.band_rows, y1 = min(y0 + L.band_rows, cy1);
    const std::uint16_t* level = reinterpret_cast<const std::uint16_t*>(responses + L.plane.offset_bytes);
    for (int x = x0 + lane_x; x < x1; x += L.lanes_x) {
      for (int y = y0; y < y1; ++y) {
        const unsigned r = __ldg(level + static_cast<long long>(y) * L.plane.pitch + x);
        if (r != 0) key = max(key, cull_key(r, y, x));
      }
    }
  }
  // Segmented reduction: the threads of one slot are contiguous, so after these steps the first
  // lane of each slot within the warp holds the maximum over that slot's lanes of the warp.
  const int lane = tid & 31;
#pragma unroll
  for (int offset = 1; offset < 32; offset <<= 1) {
    const unsigned long long other = __shfl_down_sync(kFullMask, key, offset);
    const int other_slot = __shfl_down_sync(kFullMask, slot, offset);
    if (lane + offset < 32 && other_slot == slot) key = max(key, other);
  }
  const bool head = lane == 0 || (tid - 1) / L.cell_threads != slot;
  if (head && active && key != 0) atomicMax(&best[slot], key);
  __syncthreads();

  if (tid < L.cells_per_block && first + tid < level_cells) {
    const unsigned long long k = best[tid];
    DevKeypoint kp{0, 0, 0, 0, 0};
    if (k != 0) {
      kp.x = static_cast<std::uint16_t>(0xFFFFu - static_cast<unsigned>(k & 0xFFFFu));
      kp.y = static_cast<std::uint16_t>(0xFFFFu - static_cast<unsigned>((k >> 16) & 0xFFFFu));
      kp.response = static_cast<std::uint16_t>(k >> 32);
      kp.level = static_cast<std::uint8_t>(n);
    }
    store_keypoint(cells, L.first_cell + first + tid, kp);
  }
}

// §3.4, the baseline of the culling ablation (CullLaunch::variant == kCullLog2Block): one block of
// block_threads threads per cell, all levels in one launch. Thread t takes the cell's pixels t,
// t + block_threads, ... in row-major order, then a shared-memory tree halves the candidates in
// log2(block_threads) steps. Small cells leave most of the block idle, which is what MLPT and TEWA
// avoid; the key order makes the result identical.
__global__ void __launch_bounds__(1024)
    cull_log2_kernel(const std::uint8_t* __restrict__ responses, CullLaunch p, DevKeypoint* __restrict__ cells) {
  extern __shared__ unsigned long long tree[];  // block_threads keys
  const int n = level_of_block(p.first_block, p.count, static_cast<int>(blockIdx.x));
  if (n < 0) return;  // uniform over the block
  const CullLevel& L = p.level[n];
  const int tid = static_cast<int>(threadIdx.x);
  const int threads = static_cast<int>(blockDim.x);
  const int cell = static_cast<int>(blockIdx.x) - p.first_block[n];
  const int cell_y = cell / L.cols, cell_x = cell - cell_y * L.cols;
  const int x0 = cell_x * L.cell_w, x1 = min(x0 + L.cell_w, L.plane.width);
  const int y0 = cell_y * L.cell_h, y1 = min(y0 + L.cell_h, L.plane.height);
  const int w = x1 - x0, h = y1 - y0;
  const int pixels = w > 0 && h > 0 ? w * h : 0;
  const std::uint16_t* level = reinterpret_cast<const std::uint16_t*>(responses + L.plane.offset_bytes);
  unsigned long long key = 0;
  for (int i = tid; i < pixels; i += threads) {
    const int y = y0 + i / w, x = x0 + i % w;
    const unsigned r = __ldg(level + static_cast<long long>(y) * L.plane.pitch + x);
    if (r != 0) key = max(key, cull_key(r, y, x));
  }
  tree[tid] = key;
  __syncthreads();
  for (int half = threads >> 1; half > 0; half >>= 1) {
    if (tid < half) tree[tid] = max(tree[tid], tree[tid + half]);
    __syncthreads();
  }
  if (tid == 0) {
    const unsigned long long k = tree[0];
    DevKeypoint kp{0, 0, 0, 0, 0};
    if (k != 0) {
      kp.x = static_cast<std::uint16_t>(0xFFFFu - static_cast<unsigned>(k & 0xFFFFu));
      kp.y = static_cast<std::uint16_t>(0xFFFFu - static_cast<unsigned>((k >> 16) & 0xFFFFu));
      kp.response = static_cast<std::uint16_t>(k >> 32);
      kp.level = static_cast<std::uint8_t>(n);
    }
    store_keypoint(cells, L.first_cell + cell, kp);
  }
}

// PFA's level-0 location L = Y * width0 + X of a keypoint (< 2^28 for sides <= 16384).
__device__ __forceinline__ std::uint32_t pfa_location(const DevKeypoint& kp, const PfaLaunch& p) {
  const std::int32_t s = p.scales_q16[kp.level];
  const std::uint64_t x = contract::pfa_level0(kp.x, s, p.width0 - 1);
  const std::uint64_t y = contract::pfa_level0(kp.y, s, p.height0 - 1);
  return static_cast<std::uint32_t>(y * static_cast<std::uint64_t>(p.width0) + x);
}

__device__ __forceinline__ bool pfa_counts(const DevKeypoint& kp, const PfaLaunch& p) {
  return kp.response != 0 && kp.level < p.num_scales;
}

// §3.5 step A: each keypoint adds its response to sum_map[L] and its level's bit to level_map[L];
// additions and ors commute, so the maps do not depend on the order of the atomics. The cpu
// counts distinct levels at L; popcount of the level bits is that number.
__global__ void pfa_accumulate_kernel(const DevKeypoint* __restrict__ cells, PfaLaunch p,
                                      std::uint32_t* sum_map, std::uint32_t* level_map) {
  const int i = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (i >= p.total_cells) return;
  const DevKeypoint kp = load_keypoint(cells, i);
  if (!pfa_counts(kp, p)) return;
  const std::uint32_t l = pfa_location(kp, p);
  atomicAdd(sum_map + l, static_cast<std::uint32_t>(kp.response));
  atomicOr(level_map + l, 1u << kp.level);
}

__device__ __forceinline__ std::uint32_t pfa_score(const std::uint32_t* sum_map,
                                                   const std::uint32_t* level_map, std::uint32_t l) {
  return sum_map[l] * static_cast<std::uint32_t>(__popc(level_map[l]));  // uint32, as the cpu
}

// §3.5 step B: a keypoint is rejected when a location of the window around its L (clipped to the
// level-0 image) scores strictly more; every keypoint at L decides alike.
__global__ void pfa_decide_kernel(const DevKeypoint* __restrict__ cells, PfaLaunch p,
                                  const std::uint32_t* __restrict__ sum_map,
                                  const std::uint32_t* __restrict__ level_map, std::uint8_t* rejected) {
  const int i = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (i >= p.total_cells) return;
  const DevKeypoint kp = load_keypoint(cells, i);
  std::uint8_t reject = 0;
  if (pfa_counts(kp, p)) {
    const std::uint32_t l = pfa_location(kp, p);
    const std::uint32_t own = pfa_score(sum_map, level_map, l);
    const int x = static_cast<int>(l % static_cast<std::uint32_t>(p.width0));
    const int y = static_cast<int>(l / static_cast<std::uint32_t>(p.width0));
    const int xa = max(0, x - p.reach), xb = min(p.width0 - 1, x + p.reach);
    const int ya = max(0, y - p.reach), yb = min(p.height0 - 1, y + p.reach);
    for (int wy = ya; wy <= yb && !reject; ++wy) {
      const std::uint32_t row = static_cast<std::uint32_t>(wy) * static_cast<std::uint32_t>(p.width0);
      for (int wx = xa; wx <= xb; ++wx) {
        if (pfa_score(sum_map, level_map, row + static_cast<std::uint32_t>(wx)) > own) {
          reject = 1;
          break;
        }
      }
    }
  }
  rejected[i] = reject;
}

// §3.5 step C: clears the rejected cells and returns the maps to zero (several threads may store
// the same 0: benign).
__global__ void pfa_apply_kernel(DevKeypoint* cells, PfaLaunch p, std::uint32_t* sum_map,
                                 std::uint32_t* level_map, const std::uint8_t* __restrict__ rejected) {
  const int i = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (i >= p.total_cells) return;
  const DevKeypoint kp = load_keypoint(cells, i);
  if (!pfa_counts(kp, p)) return;
  const std::uint32_t l = pfa_location(kp, p);
  sum_map[l] = 0;
  level_map[l] = 0;
  if (rejected[i]) store_keypoint(cells, i, DevKeypoint{0, 0, 0, 0, 0});
}

constexpr int kCompactThreads = 256;
constexpr int kCompactRounds = kCompactCellsPerBlock / kCompactThreads;

// Compaction, step 1: the number of non-empty cells of each block of 1024 cells.
__global__ void __launch_bounds__(kCompactThreads)
    compact_count_kernel(const DevKeypoint* __restrict__ cells, int total, std::uint32_t* block_count) {
  const int base = static_cast<int>(blockIdx.x) * kCompactCellsPerBlock;
  int count = 0;
  for (int r = 0; r < kCompactRounds; ++r) {
    const int i = base + r * kCompactThreads + static_cast<int>(threadIdx.x);
    const bool keep = i < total && load_keypoint(cells, i).response != 0;
    count += __syncthreads_count(keep);
  }
  if (threadIdx.x == 0) block_count[blockIdx.x] = static_cast<std::uint32_t>(count);
}

// Compaction, step 2: one block turns the block counts into exclusive offsets (in place, in
// chunks of 1024 with a carry) and writes the total as a little-endian uint32 at `count`.
__global__ void __launch_bounds__(1024)
    compact_scan_kernel(std::uint32_t* block_count, int num_blocks, std::uint8_t* count) {
  __shared__ std::uint32_t warp_sums[32];
  __shared__ std::uint32_t carry;
  const int tid = static_cast<int>(threadIdx.x), lane = tid & 31, warp = tid >> 5;
  if (tid == 0) carry = 0;
  __syncthreads();
  for (int base = 0; base < num_blocks; base += 1024) {
    const int i = base + tid;
    const std::uint32_t v = i < num_blocks ? block_count[i] : 0u;
    std::uint32_t inclusive = v;
#pragma unroll
    for (int offset = 1; offset < 32; offset <<= 1) {
      const std::uint32_t other = __shfl_up_sync(kFullMask, inclusive, offset);
      if (lane >= offset) inclusive += other;
    }
    if (lane == 31) warp_sums[warp] = inclusive;
    __syncthreads();
    if (warp == 0) {
      std::uint32_t w = warp_sums[lane];
#pragma unroll
      for (int offset = 1; offset < 32; offset <<= 1) {
        const std::uint32_t other = __shfl_up_sync(kFullMask, w, offset);
        if (lane >= offset) w += other;
      }
      warp_sums[lane] = w;  // inclusive over warps
    }
    __syncthreads();
    const std::uint32_t before = carry + (warp > 0 ? warp_sums[warp - 1] : 0u) + inclusive - v;
    if (i < num_blocks) block_count[i] = before;
    __syncthreads();
    if (tid == 1023) carry = before + v;
    __syncthreads();
  }
  if (tid == 0) {
    const std::uint32_t total = carry;
    count[0] = static_cast<std::uint8_t>(total & 0xFFu);
    count[1] = static_cast<std::uint8_t>((total >> 8) & 0xFFu);
    count[2] = static_cast<std::uint8_t>((total >> 16) & 0xFFu);
    count[3] = static_cast<std::uint8_t>(total >> 24);
  }
}

// Compaction, step 3: each block writes its non-empty cells, in cell order, from its offset on;
// ranks within a round of 256 cells come from warp ballots. Records at or past `capacity` are
// not written (the count is the full number either way, as the cpu's).
__global__ void __launch_bounds__(kCompactThreads)
    compact_scatter_kernel(const DevKeypoint* __restrict__ cells, int total,
                           const std::uint32_t* __restrict__ block_offset, DevKeypoint* __restrict__ items,
                           std::uint32_t capacity) {
  __shared__ std::uint32_t warp_counts[kCompactThreads / 32];
  const int tid = static_cast<int>(threadIdx.x), lane = tid & 31, warp = tid >> 5;
  const int base = static_cast<int>(blockIdx.x) * kCompactCellsPerBlock;
  std::uint32_t at = block_offset[blockIdx.x];
  for (int r = 0; r < kCompactRounds; ++r) {
    const int i = base + r * kCompactThreads + tid;
    DevKeypoint kp{0, 0, 0, 0, 0};
    if (i < total) kp = load_keypoint(cells, i);
    const bool keep = kp.response != 0;
    const unsigned ballot = __ballot_sync(kFullMask, keep);
    if (lane == 0) warp_counts[warp] = static_cast<std::uint32_t>(__popc(ballot));
    __syncthreads();
    std::uint32_t before = 0, round_total = 0;
    for (int w = 0; w < kCompactThreads / 32; ++w) {
      if (w < warp) before += warp_counts[w];
      round_total += warp_counts[w];
    }
    const std::uint32_t rank = at + before + static_cast<std::uint32_t>(__popc(ballot & ((1u << lane) - 1u)));
    if (keep && rank < capacity) store_keypoint(items, static_cast<int>(rank), kp);
    at += round_total;
    __syncthreads();  // warp_counts is rewritten by the next round
  }
}

}  // namespace

cudaError_t launch_fast_crf(const std::uint8_t* pyramid, const std::uint8_t* lut, std::uint8_t* responses,
                            const FastLaunch& p, cudaStream_t stream) {
  const int blocks = p.src.first_block[p.src.count];
  if (blocks <= 0) return cudaSuccess;
  fast_crf_kernel<<<static_cast<unsigned>(blocks), dim3(kTileW, kTileH), 0, stream>>>(pyramid, lut, responses,
                                                                                      p);
  return cudaGetLastError();
}

cudaError_t launch_cull_cells(const std::uint8_t* responses, const CullLaunch& p, DevKeypoint* cells,
                              cudaStream_t stream) {
  const int blocks = p.first_block[p.count];
  if (blocks <= 0) return cudaSuccess;
  if (p.variant == kCullLog2Block) {
    if (p.block_threads < 32 || p.block_threads > 1024 || (p.block_threads & (p.block_threads - 1)) != 0)
      return cudaErrorInvalidValue;
    cull_log2_kernel<<<static_cast<unsigned>(blocks), static_cast<unsigned>(p.block_threads),
                       sizeof(unsigned long long) * static_cast<std::size_t>(p.block_threads), stream>>>(
        responses, p, cells);
  } else {
    cull_cells_kernel<<<static_cast<unsigned>(blocks), kCullBlock, 0, stream>>>(responses, p, cells);
  }
  return cudaGetLastError();
}

cudaError_t launch_pfa_filter(DevKeypoint* cells, const PfaLaunch& p, std::uint32_t* sum_map,
                              std::uint32_t* level_map, std::uint8_t* rejected, cudaStream_t stream) {
  if (p.total_cells <= 0) return cudaSuccess;
  const unsigned grid = blocks_for(p.total_cells, 256);
  pfa_accumulate_kernel<<<grid, 256, 0, stream>>>(cells, p, sum_map, level_map);
  if (const cudaError_t e = cudaGetLastError(); e != cudaSuccess) return e;
  pfa_decide_kernel<<<grid, 256, 0, stream>>>(cells, p, sum_map, level_map, rejected);
  if (const cudaError_t e = cudaGetLastError(); e != cudaSuccess) return e;
  pfa_apply_kernel<<<grid, 256, 0, stream>>>(cells, p, sum_map, level_map, rejected);
  return cudaGetLastError();
}

cudaError_t launch_compact(const DevKeypoint* cells, int total_cells, DevKeypoint* items,
                           std::uint32_t capacity, std::uint8_t* count, std::uint32_t* block_scratch,
                           cudaStream_t stream) {
  if (total_cells <= 0) return cudaMemsetAsync(count, 0, 4, stream);
  const unsigned blocks = blocks_for(total_cells, kCompactCellsPerBlock);
  compact_count_kernel<<<blocks, kCompactThreads, 0, stream>>>(cells, total_cells, block_scratch);
  if (const cudaError_t e = cudaGetLastError(); e != cudaSuccess) return e;
  compact_scan_kernel<<<1, 1024, 0, stream>>>(block_scratch, static_cast<int>(blocks), count);
  if (const cudaError_t e = cudaGetLastError(); e != cudaSuccess) return e;
  if (capacity == 0) return cudaSuccess;
  compact_scatter_kernel<<<blocks, kCompactThreads, 0, stream>>>(cells, total_cells, block_scratch, items,
                                                                 capacity);
  return cudaGetLastError();
}

}  // namespace porta::cuda
