#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#define PFA_MAPS coherent
#include "pfa_common.glsl"

// §3.5 PFA in one workgroup (GPUs; pfa_accumulate/decide/apply elsewhere): the three steps over
// all cells, one after the other, with a workgroup barrier between them instead of a dispatch.
// Invocation t handles cells t, t + 1024, ... in every step, so `rejected[i]` is written and read
// by the same invocation; the maps, written by the atomics of step A, are read by others in step
// B after the barrier (coherent buffers, memoryBarrierBuffer). The same bytes as the three steps.
layout(local_size_x = 1024) in;

void main() {
  const uint total = uint(p.total_cells);
  const uint t = gl_LocalInvocationID.x;
  for (uint i = t; i < total; i += 1024u) pfa_accumulate_cell(i);
  memoryBarrierBuffer();
  barrier();
  for (uint i = t; i < total; i += 1024u) pfa_decide_cell(i);
  memoryBarrierBuffer();
  barrier();  // every read of the maps is done before step C clears them
  for (uint i = t; i < total; i += 1024u) pfa_apply_cell(i);
}
