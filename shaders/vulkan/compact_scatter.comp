#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "compact_common.glsl"

// Compaction, step 3: one invocation per block writes its non-empty cells, in cell order, from the
// block's offset on.
void main() {
  const uint b = porta_linear_index();
  if (b >= p.num_blocks) return;
  const uint first = b * p.block;
  const uint last = min(first + p.block, p.total_cells);
  uint at = block_count[b];
  for (uint i = first; i < last && at < p.capacity; ++i) {
    const uvec2 kp = cells[i];
    if (kp_response(kp) == 0u) continue;
    items[at++] = kp;
  }
}
