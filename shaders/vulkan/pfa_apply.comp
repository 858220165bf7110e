#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#include "pfa_common.glsl"

// §3.5 PFA, step C: clears the cells step B rejected and resets the map entries the keypoints
// touched to 0 (several invocations may write the same 0: benign).
void main() {
  const uint i = porta_linear_index();
  if (i >= uint(p.total_cells)) return;
  uvec2 kp;
  if (!pfa_keypoint(i, kp)) return;
  const uint l = pfa_location(kp);
  sum_map[l] = 0u;
  level_map[l] = 0u;
  if (uint(rejected[i]) != 0u) cells[i] = uvec2(0u);
}
