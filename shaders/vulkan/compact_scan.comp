#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "compact_common.glsl"

// Compaction, step 2: a single invocation turns block_count into exclusive offsets (in place) and
// writes the total count.
void main() {
  if (porta_linear_index() != 0u) return;
  uint total = 0u;
  for (uint b = 0u; b < p.num_blocks; ++b) {
    const uint c = block_count[b];
    block_count[b] = total;
    total += c;
  }
  for (uint k = 0u; k < 4u; ++k) count_bytes[p.count_offset + k] = uint8_t((total >> (8u * k)) & 0xFFu);
}
