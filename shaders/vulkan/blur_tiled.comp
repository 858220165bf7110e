#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.7 blur on GPUs (DESIGN.md §3.7, backends/cpu/image_kernels.cpp): both passes in one
// dispatch, one workgroup per 32 x 8 tile of any level. The tile's source with its reflect-101
// halo goes to shared memory (row r holds source row reflect101(y0 - 3 + r), column c source
// column reflect101(x0 - 3 + c)), then the horizontal sums h = sum t_k p, unrounded (the cpu's
// uint16), for the 14 rows the tile needs, then out = (sum t_k h + 2^15) >> 16: exactly the cpu's
// reflect101(x + k - 3) and reflect101(y + k - 3). Source and destination must differ (the host
// runs blur_horizontal + blur_vertical when they are the same buffer).
layout(local_size_x = PORTA_TILE_W, local_size_y = PORTA_TILE_H) in;

layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Blurred { uint8_t blurred[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  Tiles tiles;
  int taps[8];
} p;

#define HALO 3
#define IN_W (PORTA_TILE_W + 2 * HALO)
#define IN_H (PORTA_TILE_H + 2 * HALO)

shared uint source[IN_H][IN_W];
shared uint horizontal[IN_H][PORTA_TILE_W];

void main() {
  int n;
  ivec2 origin;
  PORTA_TILE_OF(p.tiles, p.layout_.count, int(porta_linear_group()), n, origin);
  if (n < 0) return;  // the whole workgroup
  const Plane level = p.layout_.level[n];
  const int tid = int(gl_LocalInvocationIndex);
  const int threads = PORTA_TILE_W * PORTA_TILE_H;
  for (int k = tid; k < IN_H * IN_W; k += threads) {
    const int r = k / IN_W, c = k - r * IN_W;
    const int sy = porta_reflect101(origin.y - HALO + r, level.height);
    const int sx = porta_reflect101(origin.x - HALO + c, level.width);
    source[r][c] = uint(pyramid[level.offset_bytes + sy * level.pitch + sx]);
  }
  barrier();
  for (int k = tid; k < IN_H * PORTA_TILE_W; k += threads) {
    const int r = k / PORTA_TILE_W, c = k - r * PORTA_TILE_W;
    uint sum = 0u;
    for (int t = 0; t < 7; ++t) sum += uint(p.taps[t]) * source[r][c + t];
    horizontal[r][c] = sum;
  }
  barrier();
  const int tx = int(gl_LocalInvocationID.x), ty = int(gl_LocalInvocationID.y);
  const int x = origin.x + tx, y = origin.y + ty;
  if (x >= level.width || y >= level.height) return;
  uint sum = 0u;  // at most 256 * 65280 + 2^15 < 2^24
  for (int t = 0; t < 7; ++t) sum += uint(p.taps[t]) * horizontal[ty + t][tx];
  blurred[level.offset_bytes + y * level.pitch + x] = uint8_t((sum + (1u << 15)) >> 16);
}
