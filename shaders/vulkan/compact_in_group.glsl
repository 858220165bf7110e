// Compaction in one workgroup of COMPACT_THREADS invocations (compact_group.comp,
// pfa_compact_group.comp, fast_cull_finish.comp): the same output as compact_count/scan/scatter.
// The including shader declares `cells` (uvec2, readable), `items` (uvec2, writable) and
// `count_bytes` (uint8_t, writable) and defines COMPACT_THREADS (a multiple of 32). The cells go
// by in tiles of 4 * COMPACT_THREADS: each invocation counts its 4 cells; 32 invocations each sum
// the counts of a run of COMPACT_THREADS / 32 invocations, and each of them adds up the runs before
// its own; every invocation then adds its run's start to the counts before it in the run, which
// gives where its cells go, and writes them (records at or past `capacity` not written). Four
// barriers a tile, where a scan over all the invocations takes two per doubling (16 at 256). The
// tile's total moves the base on. The count goes as a little-endian uint32 to byte `count_offset`.
const uint kCompactPerThread = 4u;
const uint kCompactRuns = 32u;
const uint kCompactRun = COMPACT_THREADS / kCompactRuns;  // invocations per run
shared uint compact_counts[COMPACT_THREADS];
shared uint compact_run_sums[kCompactRuns];
shared uint compact_run_starts[kCompactRuns + 1u];  // [kCompactRuns]: the tile's total

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
    compact_counts[t] = count;
    barrier();
    if (t < kCompactRuns) {
      uint sum = 0u;
      for (uint j = 0u; j < kCompactRun; ++j) sum += compact_counts[t * kCompactRun + j];
      compact_run_sums[t] = sum;
    }
    barrier();
    if (t <= kCompactRuns) {  // the runs before run t (all of them for t == kCompactRuns)
      uint start = 0u;
      for (uint j = 0u; j < t; ++j) start += compact_run_sums[j];
      compact_run_starts[t] = start;
    }
    barrier();
    const uint run = t / kCompactRun;
    uint at = base + compact_run_starts[run];
    for (uint j = run * kCompactRun; j < t; ++j) at += compact_counts[j];
    const uint tile_total = compact_run_starts[kCompactRuns];
    barrier();  // every invocation has read the counts before the next tile writes them
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
