#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// Compaction in one workgroup (GPUs; compact_count/scan/scatter elsewhere): the same output as
// the three steps, the non-empty cells (response > 0) in cell order into `items` (records at or
// past `capacity` not written) and their number as a little-endian uint32 at byte `count_offset`
// of `count_bytes`. The cells go by in tiles of 4 * 256: each invocation counts its 4 cells, an
// exclusive prefix sum over the workgroup in shared memory gives where they go, then it writes
// them; the tile's total moves the base on.
layout(local_size_x = 256) in;

layout(std430, set = 0, binding = 0) readonly buffer CellsBuffer { uvec2 cells[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Items { uvec2 items[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Count { uint8_t count_bytes[]; };
layout(std430, push_constant) uniform Params {
  uint total_cells;
  uint capacity;
  uint count_offset;
} p;

const uint kThreads = 256u;
const uint kPerThread = 4u;
shared uint sums[kThreads];

void main() {
  const uint t = gl_LocalInvocationID.x;
  uint base = 0u;
  for (uint tile = 0u; tile < p.total_cells; tile += kThreads * kPerThread) {
    const uint first = tile + t * kPerThread;
    uvec2 kp[kPerThread];
    uint count = 0u;
    for (uint k = 0u; k < kPerThread; ++k) {
      const uint i = first + k;
      kp[k] = i < p.total_cells ? cells[i] : uvec2(0u);
      count += kp_response(kp[k]) != 0u ? 1u : 0u;
    }
    sums[t] = count;
    barrier();
    for (uint off = 1u; off < kThreads; off <<= 1u) {
      const uint v = t >= off ? sums[t - off] : 0u;
      barrier();
      sums[t] += v;
      barrier();
    }
    uint at = base + sums[t] - count;
    const uint tile_total = sums[kThreads - 1u];
    barrier();  // every invocation has read sums before the next tile writes it
    for (uint k = 0u; k < kPerThread; ++k) {
      if (kp_response(kp[k]) == 0u) continue;
      if (at < p.capacity) items[at] = kp[k];
      ++at;
    }
    base += tile_total;
  }
  if (t == 0u)
    for (uint k = 0u; k < 4u; ++k) count_bytes[p.count_offset + k] = uint8_t((base >> (8u * k)) & 0xFFu);
}
