// Device helpers shared by the CUDA kernels: list lengths, level lookup of a block, keypoint
// records and descriptor distances. Device code only; included by the .cu files.
#pragma once

#include <cstdint>

#include "porta/contract_math.hpp"
#include "cuda/kernels.hpp"

namespace porta::cuda {

inline constexpr unsigned kFullMask = 0xFFFFFFFFu;

/// The list's length, at most its usable capacity (read bytewise: any count offset works).
__device__ __forceinline__ int list_count(DevCount c) {
  if (c.capacity <= 0) return 0;  // an empty list need not have a count to read
  const std::uint32_t n =
      static_cast<std::uint32_t>(c.bytes[0]) | (static_cast<std::uint32_t>(c.bytes[1]) << 8) |
      (static_cast<std::uint32_t>(c.bytes[2]) << 16) | (static_cast<std::uint32_t>(c.bytes[3]) << 24);
  return n < static_cast<std::uint32_t>(c.capacity) ? static_cast<int>(n) : c.capacity;
}

/// The level owning block `block` of a launch tiled by `first_block` (count + 1 entries); -1 past
/// the last level.
__device__ __forceinline__ int level_of_block(const int* first_block, int count, int block) {
  for (int n = 0; n < count; ++n)
    if (block < first_block[n + 1]) return n;
  return -1;
}

/// A keypoint record as one 8-byte load (records start at byte 0 of a cudaMalloc'ed buffer).
__device__ __forceinline__ DevKeypoint load_keypoint(const DevKeypoint* records, int i) {
  const unsigned long long bits = reinterpret_cast<const unsigned long long*>(records)[i];
  DevKeypoint kp;
  kp.x = static_cast<std::uint16_t>(bits & 0xFFFFu);
  kp.y = static_cast<std::uint16_t>((bits >> 16) & 0xFFFFu);
  kp.response = static_cast<std::uint16_t>((bits >> 32) & 0xFFFFu);
  kp.level = static_cast<std::uint8_t>((bits >> 48) & 0xFFu);
  kp.angle_bin = static_cast<std::uint8_t>(bits >> 56);
  return kp;
}

__device__ __forceinline__ void store_keypoint(DevKeypoint* records, int i, DevKeypoint kp) {
  const unsigned long long bits = static_cast<unsigned long long>(kp.x) |
                                  (static_cast<unsigned long long>(kp.y) << 16) |
                                  (static_cast<unsigned long long>(kp.response) << 32) |
                                  (static_cast<unsigned long long>(kp.level) << 48) |
                                  (static_cast<unsigned long long>(kp.angle_bin) << 56);
  reinterpret_cast<unsigned long long*>(records)[i] = bits;
}

/// A 256-bit descriptor as four 64-bit words (descriptors are 32-byte records from byte 0).
struct Desc256 {
  unsigned long long w[4];
};

__device__ __forceinline__ Desc256 load_descriptor(const std::uint8_t* descriptors, long long i) {
  const ulonglong2* p = reinterpret_cast<const ulonglong2*>(descriptors + i * 32);
  const ulonglong2 a = __ldg(p);
  const ulonglong2 b = __ldg(p + 1);
  return Desc256{{a.x, a.y, b.x, b.y}};
}

/// Popcount of the XOR, in [0, 256] (stereo::hamming_distance).
__device__ __forceinline__ int hamming(const Desc256& a, const Desc256& b) {
  return __popcll(a.w[0] ^ b.w[0]) + __popcll(a.w[1] ^ b.w[1]) + __popcll(a.w[2] ^ b.w[2]) +
         __popcll(a.w[3] ^ b.w[3]);
}

/// Blocks of `per_block` items that cover `items` (host side, for grids).
inline unsigned blocks_for(long long items, int per_block) {
  return static_cast<unsigned>((items + per_block - 1) / per_block);
}

}  // namespace porta::cuda
