#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#include "pfa_common.glsl"

// §3.5 PFA, step A: each keypoint adds its response to sum_map[L] and its level bit to
// level_map[L]. The atomics commute, so the maps do not depend on their order.
void main() {
  const uint i = porta_linear_index();
  if (i >= uint(p.total_cells)) return;
  uvec2 kp;
  if (!pfa_keypoint(i, kp)) return;
  const uint l = pfa_location(kp);
  atomicAdd(sum_map[l], kp_response(kp));
  atomicOr(level_map[l], 1u << kp_level(kp));
}
