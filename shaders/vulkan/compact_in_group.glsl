// Compaction in one workgroup of COMPACT_THREADS invocations (compact_group.comp,
// pfa_compact_group.comp): the same output as compact_count/scan/scatter. The including shader
// declares `cells` (uvec2, readable), `items` (uvec2, writable) and `count_bytes` (uint8_t,
// writable) and defines COMPACT_THREADS. The cells go by in tiles of 4 * COMPACT_THREADS: each
// invocation counts its 4 cells, an inclusive prefix sum over the workgroup in shared memory gives
// where they go, then it writes them (records at or past `capacity` not written); the tile's total
// moves the base on. The count goes as a little-endian uint32 to byte `count_offset`.
const uint kCompactPerThread = 4u;
shared uint compact_sums[COMPACT_THREADS];

void compact_in_group(uint total_cells, uint capacity, uint count_offset) {
  const uint t = gl_LocalInvocationID.x;
  uint base = 0u;
  for (uint tile = 0u; tile < total_cells; tile += COMPACT_THREADS * kCompactPerThread) {
    const uint first = tile + t * kCompactPerThread;
    uvec2 kp[kCompactPerThread];
    uint count = 0u;
    for (uint k = 0u; k < kCompactPerThread; ++k) {
      const uint i = first + k;
      kp[k] = i < total_cells ? cells[i] : uvec2(0u);
      count += kp_response(kp[k]) != 0u ? 1u : 0u;
    }
    compact_sums[t] = count;
    barrier();
    for (uint off = 1u; off < COMPACT_THREADS; off <<= 1u) {
      const uint v = t >= off ? compact_sums[t - off] : 0u;
      barrier();
      compact_sums[t] += v;
      barrier();
    }
    uint at = base + compact_sums[t] - count;
    const uint tile_total = compact_sums[COMPACT_THREADS - 1u];
    barrier();  // every invocation has read the sums before the next tile writes them
    for (uint k = 0u; k < kCompactPerThread; ++k) {
      if (kp_response(kp[k]) == 0u) continue;
      if (at < capacity) items[at] = kp[k];
      ++at;
    }
    base += tile_total;
  }
  if (t == 0u)
    for (uint k = 0u; k < 4u; ++k) count_bytes[count_offset + k] = uint8_t((base >> (8u * k)) & 0xFFu);
}
