#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.3 FAST CRF on GPUs (DESIGN.md §3.3, fast_crf.comp): one workgroup per 32 x 8 tile of any
// level, one dispatch. The tile and its 3-pixel halo are read into shared memory once (clamped
// to the level: a pixel whose circle leaves the level is within `edge` >= 3 of its border and gets
// 0 without reading it), then each invocation tests its pixel's circle there. Same bytes as
// fast_crf.comp.
layout(local_size_x = PORTA_TILE_W, local_size_y = PORTA_TILE_H) in;

layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Lut { uint8_t lut[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Responses { uint16_t responses[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels src;  // empty levels have no tiles
  Levels dst;
  Tiles tiles;
  int eps;
  int edge;
} p;

#define HALO 3
#define IN_W (PORTA_TILE_W + 2 * HALO)
#define IN_H (PORTA_TILE_H + 2 * HALO)

shared int source[IN_H][IN_W];

// The radius-3 Bresenham circle (tables.hpp kFastCircle), clockwise from 12 o'clock.
const int kDx[16] = int[16](0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3, -3, -3, -2, -1);
const int kDy[16] = int[16](-3, -3, -2, -1, 0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3);

void main() {
  int n;
  ivec2 origin;
  PORTA_TILE_OF(p.tiles, p.src.count, int(porta_linear_group()), n, origin);
  if (n < 0) return;  // the whole workgroup
  const Plane s = p.src.level[n];
  const int tid = int(gl_LocalInvocationIndex);
  for (int k = tid; k < IN_H * IN_W; k += PORTA_TILE_W * PORTA_TILE_H) {
    const int r = k / IN_W, c = k - r * IN_W;
    const int sy = clamp(origin.y - HALO + r, 0, s.height - 1);
    const int sx = clamp(origin.x - HALO + c, 0, s.width - 1);
    source[r][c] = int(pyramid[s.offset_bytes + sy * s.pitch + sx]);
  }
  barrier();
  const int tx = int(gl_LocalInvocationID.x), ty = int(gl_LocalInvocationID.y);
  const int x = origin.x + tx, y = origin.y + ty;
  if (x >= s.width || y >= s.height) return;
  uint response = 0u;
  if (y >= p.edge && y < s.height - p.edge && x >= p.edge && x < s.width - p.edge) {
    const int c = source[ty + HALO][tx + HALO];
    uint bright = 0u, dark = 0u;
    int sum = 0;
    for (int i = 0; i < 16; ++i) {
      const int q = source[ty + HALO + kDy[i]][tx + HALO + kDx[i]];
      // Two independent tests, as in the contract.
      if (q > c + p.eps) bright |= 1u << i;
      if (q < c - p.eps) dark |= 1u << i;
      sum += abs(q - c);
    }
    if ((uint(lut[bright]) | uint(lut[dark])) != 0u) response = uint(sum);  // <= 4080
  }
  const Plane d = p.dst.level[n];
  responses[d.offset_bytes / 2 + y * d.pitch + x] = uint16_t(response);
}
