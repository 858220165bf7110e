#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "blur_common.glsl"

// §3.7 blur, vertical pass: out = (sum t_k * h(reflect101(y + k - 3)) + 2^15) >> 16 into the
// blurred pyramid (same layout as the source); one invocation per row.
layout(std430, set = 0, binding = 0) readonly buffer Scratch { uint16_t scratch[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Blurred { uint8_t blurred[]; };

void main() {
  int y;
  const int n = blur_locate_row(int(porta_linear_index()), y);
  if (n < 0) return;
  const Plane level = p.layout_.level[n];
  const int w = level.width, h = level.height;
  const int plane = p.scratch_offset[n];
  const int h0 = plane + porta_reflect101(y - 3, h) * w, h1 = plane + porta_reflect101(y - 2, h) * w;
  const int h2 = plane + porta_reflect101(y - 1, h) * w, h3 = plane + y * w;
  const int h4 = plane + porta_reflect101(y + 1, h) * w, h5 = plane + porta_reflect101(y + 2, h) * w;
  const int h6 = plane + porta_reflect101(y + 3, h) * w;
  const int base = level.offset_bytes + y * level.pitch;
  const uint t0 = uint(p.taps[0]), t1 = uint(p.taps[1]), t2 = uint(p.taps[2]), t3 = uint(p.taps[3]);
  const uint t4 = uint(p.taps[4]), t5 = uint(p.taps[5]), t6 = uint(p.taps[6]);
  for (int x = 0; x < w; ++x) {
    const uint sum = t0 * uint(scratch[h0 + x]) + t1 * uint(scratch[h1 + x]) + t2 * uint(scratch[h2 + x]) +
                     t3 * uint(scratch[h3 + x]) + t4 * uint(scratch[h4 + x]) + t5 * uint(scratch[h5 + x]) +
                     t6 * uint(scratch[h6 + x]);
    blurred[base + x] = uint8_t((sum + (1u << 15)) >> 16);
  }
}
