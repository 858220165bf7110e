#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "blur_common.glsl"

// §3.7 blur, horizontal pass: h = sum t_k * p(reflect101(x + k - 3)) unrounded (at most
// 255 * 256: fits uint16), into the level's scratch plane; one invocation per row, the three
// columns at each end by reflect101 and the rest without it.
layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Scratch { uint16_t scratch[]; };

void main() {
  int y;
  const int n = blur_locate_row(int(porta_linear_index()), y);
  if (n < 0) return;
  const Plane level = p.layout_.level[n];
  const int w = level.width;
  const int row = level.offset_bytes + y * level.pitch;
  const int base = p.scratch_offset[n] + y * w;
  const uint t0 = uint(p.taps[0]), t1 = uint(p.taps[1]), t2 = uint(p.taps[2]), t3 = uint(p.taps[3]);
  const uint t4 = uint(p.taps[4]), t5 = uint(p.taps[5]), t6 = uint(p.taps[6]);
  const int head = min(3, w), tail = max(head, w - 3);
  for (int x = 0; x < w; x = x + 1 == head ? tail : x + 1) {  // the ends: x < head and x >= tail
    uint sum = 0u;
    for (int k = 0; k < 7; ++k) sum += uint(p.taps[k]) * uint(pyramid[row + porta_reflect101(x + k - 3, w)]);
    scratch[base + x] = uint16_t(sum);
  }
  for (int x = head; x < tail; ++x) {
    const int c = row + x;
    scratch[base + x] = uint16_t(t0 * uint(pyramid[c - 3]) + t1 * uint(pyramid[c - 2]) + t2 * uint(pyramid[c - 1]) +
                                t3 * uint(pyramid[c]) + t4 * uint(pyramid[c + 1]) + t5 * uint(pyramid[c + 2]) +
                                t6 * uint(pyramid[c + 3]));
  }
}
