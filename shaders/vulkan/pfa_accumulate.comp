#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#include "pfa_common.glsl"

// §3.5 PFA, step A (pfa_accumulate_cell), one invocation per cell.
layout(local_size_x = 64) in;

void main() {
  const uint i = porta_linear_index();
  if (i < uint(p.total_cells)) pfa_accumulate_cell(i);
}
