#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.2 pyramid on GPUs, levels 1..m in one dispatch (DESIGN.md §3.2, pyramid_common.glsl): one
// workgroup per 32 x 8 tile of any of those levels. A tile of level n reads a region of level
// n - 1, which reads a region of level n - 2, and so on down to level 0; the workgroup computes
// those regions of levels 1..n-1 from level 0 into shared memory, level by level, each pixel
// exactly as the per-level kernel computes it, then its tile from the last one. Work is repeated
// across tiles (their regions overlap), dispatches and barriers between levels are not.
// Regions of the contract's tables (build_resize_tables: source indices never decrease) are
// bounded by the first and last pixel's sources; the host fuses only the levels whose regions fit
// (checks::fused_pyramid_levels), and an index outside a region is clamped into shared memory.
layout(local_size_x = PORTA_TILE_W, local_size_y = PORTA_TILE_H) in;

layout(std430, set = 0, binding = 0) buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Table { int table[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels planes;  // every level (level 0 is read, levels 1..m written)
  Tiles tiles;    // tiles of levels 1..m only
  int table_offset[PORTA_MAX_LEVELS];  // of level n's tables at [n] (ResizeTables::level_offset[n - 1])
} p;

// Two regions of 8 KiB, 4 pixels per word, rows padded to a word (kFusedPyramidBytes on the host).
#define REGION_WORDS 2048
shared uint region[2 * REGION_WORDS];

// Source pixel (x, y) of level k - 1: the pyramid for level 0, else the region of level k - 1 in
// the buffer at word `base`, whose top-left pixel is (xa, ya) and rows are `stride` bytes.
uint fetch(int k, int base, int stride, int xa, int ya, int x, int y) {
  if (k == 1) {
    const Plane s = p.planes.level[0];
    return uint(pyramid[s.offset_bytes + y * s.pitch + x]);
  }
  const int i = clamp((y - ya) * stride + (x - xa), 0, 4 * REGION_WORDS - 1);
  return (region[base + (i >> 2)] >> (8 * (i & 3))) & 255u;
}

#include "resize_taps.glsl"

// Pixel (x, y) of level k from level k - 1.
uint resample(int k, int base, int stride, int xa, int ya, int x, int y) {
  const ResizeTaps t = resize_taps(p.table_offset[k], p.planes.level[k - 1], p.planes.level[k], x, y);
  return resize_value(t, fetch(k, base, stride, xa, ya, t.x0, t.y0), fetch(k, base, stride, xa, ya, t.x1, t.y0),
                      fetch(k, base, stride, xa, ya, t.x0, t.y1), fetch(k, base, stride, xa, ya, t.x1, t.y1));
}

void main() {
  int n;
  ivec2 origin;
  PORTA_TILE_OF(p.tiles, p.planes.count, int(porta_linear_group()), n, origin);
  if (n < 1) return;  // the whole workgroup

  // The region of each level k <= n that the tile needs, [xa, xb] x [ya, yb], from level n down.
  int xa[PORTA_MAX_LEVELS], xb[PORTA_MAX_LEVELS], ya[PORTA_MAX_LEVELS], yb[PORTA_MAX_LEVELS];
  xa[n] = origin.x;
  xb[n] = min(origin.x + PORTA_TILE_W, p.planes.level[n].width) - 1;
  ya[n] = origin.y;
  yb[n] = min(origin.y + PORTA_TILE_H, p.planes.level[n].height) - 1;
  for (int k = n; k >= 2; --k) {
    const int cols = p.table_offset[k];
    const int rows = cols + 2 * p.planes.level[k].width;
    xa[k - 1] = table[cols + xa[k]];
    xb[k - 1] = min(table[cols + xb[k]] + 1, p.planes.level[k - 1].width - 1);
    ya[k - 1] = table[rows + ya[k]];
    yb[k - 1] = min(table[rows + yb[k]] + 1, p.planes.level[k - 1].height - 1);
  }

  const int tid = int(gl_LocalInvocationIndex);
  for (int k = 1; k < n; ++k) {  // regions of levels 1..n-1 into shared memory, 4 pixels per step
    const int src_base = ((k - 1) & 1) * REGION_WORDS;
    const int src_stride = k == 1 ? 0 : ((xb[k - 1] - xa[k - 1] + 4) >> 2) * 4;
    const int dst_base = (k & 1) * REGION_WORDS;
    const int cols = xb[k] - xa[k] + 1;
    const int words = (cols + 3) >> 2;
    const int steps = words * (yb[k] - ya[k] + 1);
    for (int q = tid; q < steps; q += PORTA_TILE_W * PORTA_TILE_H) {
      const int r = q / words, c = (q - r * words) * 4;
      uint word = 0u;
      for (int e = 0; e < 4 && c + e < cols; ++e)
        word |= resample(k, src_base, src_stride, xa[k - 1], ya[k - 1], xa[k] + c + e, ya[k] + r) << (8 * e);
      region[dst_base + min(q, REGION_WORDS - 1)] = word;
    }
    barrier();
  }
  const int x = origin.x + int(gl_LocalInvocationID.x), y = origin.y + int(gl_LocalInvocationID.y);
  const Plane level = p.planes.level[n];
  if (x >= level.width || y >= level.height) return;
  const int src_stride = n == 1 ? 0 : ((xb[n - 1] - xa[n - 1] + 4) >> 2) * 4;
  pyramid[level.offset_bytes + y * level.pitch + x] =
      uint8_t(resample(n, ((n - 1) & 1) * REGION_WORDS, src_stride, xa[n - 1], ya[n - 1], x, y));
}
