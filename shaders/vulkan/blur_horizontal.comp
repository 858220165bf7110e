#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "blur_common.glsl"

// §3.7 blur, horizontal pass: h = sum t_k * p(reflect101(x + k - 3)) unrounded (at most
// 255 * 256: fits uint16), into the level's scratch plane.
layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Scratch { uint16_t scratch[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x);
  int y;
  const int n = blur_locate_row(int(gl_GlobalInvocationID.y), y);
  if (n < 0) return;
  const Plane level = p.layout_.level[n];
  if (x >= level.width) return;
  const int row = level.offset_bytes + y * level.pitch;
  uint sum = 0u;
  for (int k = 0; k < 7; ++k) sum += uint(p.taps[k]) * uint(pyramid[row + porta_reflect101(x + k - 3, level.width)]);
  scratch[p.scratch_offset[n] + y * level.width + x] = uint16_t(sum);
}
