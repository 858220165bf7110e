#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#define PFA_MAPS coherent
#define PFA_CELLS coherent
// After PFA's parameters and the host struct's 3 words of padding (PfaCompactParams).
#define PFA_EXTRA_PARAMS \
  int pfa_pad0;          \
  int pfa_pad1;          \
  int pfa_pad2;          \
  uint pfa_steps;        \
  uint capacity;         \
  uint count_offset;
#include "pfa_common.glsl"

// §3.5 PFA and the compaction in one workgroup (GPUs; the backend's detect_keypoints):
// pfa_group.comp's steps that pfa_steps names (uniform; bit 0 step A, bit 1 step B, bit 2 step C:
// the steps before them ran elsewhere, fast_cull.comp's step A and pfa_decide.comp's step B), then
// compact_group.comp's scan with 1024 invocations, a barrier instead of a dispatch between them.
// Steps A and B loop over every cell in one workgroup, so the backend gives them to it only for a
// few hundred cells; step C and the scan, any number. The same bytes as pfa_filter then
// compact_keypoints.
layout(local_size_x = 1024) in;

layout(std430, set = 0, binding = 4) writeonly buffer Items { uvec2 items[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Count { uint8_t count_bytes[]; };

#define COMPACT_THREADS 1024u
#include "compact_in_group.glsl"

void main() {
  const uint total = uint(p.total_cells);
  const uint t = gl_LocalInvocationID.x;
  if ((p.pfa_steps & 1u) != 0u) {
    for (uint i = t; i < total; i += 1024u) pfa_accumulate_cell(i);
    memoryBarrierBuffer();
    barrier();
  }
  if ((p.pfa_steps & 2u) != 0u) {
    for (uint i = t; i < total; i += 1024u) pfa_decide_cell(i);
    memoryBarrierBuffer();
    barrier();  // every read of the maps is done before step C clears them
  }
  if ((p.pfa_steps & 4u) != 0u) {
    for (uint i = t; i < total; i += 1024u) pfa_apply_cell(i);
    memoryBarrierBuffer();
    barrier();  // the cleared cells are read by other invocations below
  }
  compact_in_group(total, p.capacity, p.count_offset);
}
