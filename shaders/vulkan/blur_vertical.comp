#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "blur_common.glsl"

// §3.7 blur, vertical pass: out = (sum t_k * h(reflect101(y + k - 3)) + 2^15) >> 16 into the
// blurred pyramid (same layout as the source).
layout(std430, set = 0, binding = 0) readonly buffer Scratch { uint16_t scratch[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Blurred { uint8_t blurred[]; };

void main() {
  const int x = int(gl_GlobalInvocationID.x);
  int y;
  const int n = blur_locate_row(int(gl_GlobalInvocationID.y), y);
  if (n < 0) return;
  const Plane level = p.layout_.level[n];
  if (x >= level.width) return;
  const int column = p.scratch_offset[n] + x;
  uint sum = 0u;
  for (int k = 0; k < 7; ++k)
    sum += uint(p.taps[k]) * uint(scratch[column + porta_reflect101(y + k - 3, level.height) * level.width]);
  blurred[level.offset_bytes + y * level.pitch + x] = uint8_t((sum + (1u << 15)) >> 16);
}
