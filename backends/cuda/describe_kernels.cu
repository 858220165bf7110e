// Orientation and ORB descriptor kernels of the CUDA backend (DESIGN.md §3.6, §3.8): one warp per
// keypoint list slot, every level in the same launch; launched over the list's capacity, the
// length is read on the device. The cpu backend (backends/cpu/describe_kernels.cpp) defines the
// result.
#include <cstdint>

#include "cuda/device_common.cuh"

namespace porta::cuda {

namespace {

constexpr int kOrientRadius = 15;
constexpr int kOrbReach = 18;
constexpr int kWarpsPerBlock = 4;

struct Umax {
  int v[kOrientRadius + 1];
};

// A keypoint whose level exists and which lies at least `reach` px inside it. The cpu backend
// refuses any other keypoint with an error before it starts; here it is left untouched.
__device__ __forceinline__ bool keypoint_inside(const DevKeypoint& kp, const DevLevels& layout, int reach) {
  if (kp.level >= layout.count) return false;
  const DevPlane& plane = layout.level[kp.level];
  return kp.x >= reach && kp.y >= reach && kp.x + reach < plane.width && kp.y + reach < plane.height;
}

__device__ __forceinline__ int warp_sum(int v) {
#pragma unroll
  for (int offset = 16; offset > 0; offset >>= 1) v += __shfl_xor_sync(kFullMask, v, offset);
  return v;
}

// §3.6: lane l < 31 owns column dx = l - 15 of the disc and walks its rows (coalesced row reads);
// m10 = sum dx * I and m01 = sum dy * I are then summed over the warp (integers: the order of the
// additions cannot change them). The bin is the first b with cross(u_b, m) >= 0 > cross(u_{b+1}, m),
// bin 0 when none: each lane tests bins lane, lane + 32, ... and the warp takes the smallest.
__global__ void __launch_bounds__(32 * kWarpsPerBlock)
    orient_kernel(const std::uint8_t* __restrict__ pyramid, DevLevels layout, DevKeypoint* keypoints,
                  DevCount count, Umax umax, const std::int32_t* __restrict__ boundaries, int bins) {
  const int i = static_cast<int>((blockIdx.x * blockDim.x + threadIdx.x) >> 5);
  const int lane = static_cast<int>(threadIdx.x & 31);
  if (i >= list_count(count)) return;  // uniform over the warp
  const DevKeypoint kp = load_keypoint(keypoints, i);
  if (!keypoint_inside(kp, layout, kOrientRadius)) return;
  const DevPlane plane = layout.level[kp.level];
  const std::uint8_t* centre =
      pyramid + plane.offset_bytes + static_cast<long long>(kp.y) * plane.pitch + kp.x;

  const int dx = lane - kOrientRadius;
  const int adx = dx < 0 ? -dx : dx;
  int column_sum = 0, m01 = 0;
  if (lane < 2 * kOrientRadius + 1) {
    for (int dy = -kOrientRadius; dy <= kOrientRadius; ++dy) {
      if (adx > umax.v[dy < 0 ? -dy : dy]) continue;
      const int v = __ldg(centre + static_cast<long long>(dy) * plane.pitch + dx);
      column_sum += v;
      m01 += dy * v;
    }
  }
  // |m| <= 255 * sum over the half disc of |dx| < 2^20: int holds both moments.
  const int m10 = warp_sum(dx * column_sum);
  m01 = warp_sum(m01);

  int first = bins;
  for (int b = lane; b < bins; b += 32) {
    const int next = b + 1 == bins ? 0 : b + 1;
    const std::int32_t cross_b =
        contract::orientation_cross(__ldg(boundaries + 2 * b), __ldg(boundaries + 2 * b + 1), m10, m01);
    const std::int32_t cross_next =
        contract::orientation_cross(__ldg(boundaries + 2 * next), __ldg(boundaries + 2 * next + 1), m10, m01);
    if (cross_b >= 0 && cross_next < 0) {
      first = b;
      break;
    }
  }
#pragma unroll
  for (int offset = 16; offset > 0; offset >>= 1)
    first = min(first, __shfl_xor_sync(kFullMask, first, offset));
  if (lane == 0)
    reinterpret_cast<std::uint8_t*>(keypoints)[static_cast<long long>(i) * 8 + 7] =
        static_cast<std::uint8_t>(first < bins ? first : 0);
}

// §3.8: lane k writes byte k of the descriptor: bits j = 8k .. 8k+7, bit j = I(p + a_j) < I(p + b_j)
// on the blurred level, with the pairs of the keypoint's angle bin (pattern: bins x 256 x (ax, ay,
// bx, by) int8). A warp's 32 byte stores are one 32-byte descriptor.
__global__ void __launch_bounds__(32 * kWarpsPerBlock)
    orb_describe_kernel(const std::uint8_t* __restrict__ blurred, DevLevels layout,
                        const DevKeypoint* __restrict__ keypoints, DevCount count,
                        const std::int8_t* __restrict__ pattern, int bins,
                        std::uint8_t* __restrict__ descriptors) {
  const int i = static_cast<int>((blockIdx.x * blockDim.x + threadIdx.x) >> 5);
  const int lane = static_cast<int>(threadIdx.x & 31);
  if (i >= list_count(count)) return;
  const DevKeypoint kp = load_keypoint(keypoints, i);
  if (!keypoint_inside(kp, layout, kOrbReach) || kp.angle_bin >= bins) return;
  const DevPlane plane = layout.level[kp.level];
  const std::uint8_t* centre =
      blurred + plane.offset_bytes + static_cast<long long>(kp.y) * plane.pitch + kp.x;
  const char4* pairs =
      reinterpret_cast<const char4*>(pattern) + static_cast<long long>(kp.angle_bin) * 256 + lane * 8;
  unsigned bits = 0;
#pragma unroll
  for (int bit = 0; bit < 8; ++bit) {
    const char4 q = __ldg(pairs + bit);  // (ax, ay, bx, by)
    const std::uint8_t a = __ldg(centre + static_cast<long long>(q.y) * plane.pitch + q.x);
    const std::uint8_t b = __ldg(centre + static_cast<long long>(q.w) * plane.pitch + q.z);
    bits |= static_cast<unsigned>(a < b) << bit;
  }
  descriptors[static_cast<long long>(i) * 32 + lane] = static_cast<std::uint8_t>(bits);
}

}  // namespace

cudaError_t launch_orient(const std::uint8_t* pyramid, const DevLevels& layout, DevKeypoint* keypoints,
                          DevCount count, DevUmax umax, const std::int32_t* boundaries, int bins,
                          cudaStream_t stream) {
  if (count.capacity <= 0) return cudaSuccess;
  Umax u{};
  for (int k = 0; k <= kOrientRadius; ++k) u.v[k] = umax.v[k];
  orient_kernel<<<blocks_for(count.capacity, kWarpsPerBlock), 32 * kWarpsPerBlock, 0, stream>>>(
      pyramid, layout, keypoints, count, u, boundaries, bins);
  return cudaGetLastError();
}

cudaError_t launch_orb_describe(const std::uint8_t* blurred, const DevLevels& layout,
                                const DevKeypoint* keypoints, DevCount count, const std::int8_t* pattern,
                                int bins, std::uint8_t* descriptors, cudaStream_t stream) {
  if (count.capacity <= 0) return cudaSuccess;
  orb_describe_kernel<<<blocks_for(count.capacity, kWarpsPerBlock), 32 * kWarpsPerBlock, 0, stream>>>(
      blurred, layout, keypoints, count, pattern, bins, descriptors);
  return cudaGetLastError();
}

}  // namespace porta::cuda
