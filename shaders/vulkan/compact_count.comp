#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "compact_common.glsl"

// Compaction, step 1: one invocation per block; block_count[b] = its number of non-empty cells.
void main() {
  const uint b = porta_linear_index();
  if (b >= p.num_blocks) return;
  const uint first = b * p.block;
  const uint last = min(first + p.block, p.total_cells);
  uint count = 0u;
  for (uint i = first; i < last; ++i) count += kp_response(cells[i]) != 0u ? 1u : 0u;
  block_count[b] = count;
}
