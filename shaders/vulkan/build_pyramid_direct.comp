#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.2 pyramid on GPUs, levels s+1..e (e - s <= 3) in one dispatch straight from level s, without
// shared memory or barriers: one invocation per pixel of those levels computes its pixel from the
// four pixels of the level above that the contract's taps name, each of those from its four, and
// so on down to level s (4, 16 or 64 reads of level s; the intermediate pixels are recomputed, as
// the per-level kernel computes them, by every invocation that needs them). Each value is rounded
// to 8 bits at its own level as §3.2 says, so the bytes are those of one dispatch per level; the
// repeated arithmetic costs a GPU less than the barriers and launches between levels it saves.
layout(local_size_x = 256) in;

layout(std430, set = 0, binding = 0) buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Table { int table[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels planes;                       // every level (level s is read, levels s+1..e written)
  int table_offset[PORTA_MAX_LEVELS];  // of level n's tables at [n] (ResizeTables::level_offset[n - 1])
  int first_pixel[PORTA_MAX_LEVELS + 1];  // invocation of level n's first pixel at [n], s+1 <= n <= e + 1
  int source;                          // s
  int last;                            // e
  int pad0;
  int pad1;
} p;

#include "resize_taps.glsl"

// Pixel (x, y) of level k, read from level k (k == s) or computed from level k - 1 (k == s + 1).
uint from_source(int k, int x, int y) {
  const Plane above = p.planes.level[k - 1];
  const ResizeTaps t = resize_taps(p.table_offset[k], above, p.planes.level[k], x, y);
  const int top = above.offset_bytes + t.y0 * above.pitch;
  const int bottom = above.offset_bytes + t.y1 * above.pitch;
  return resize_value(t, uint(pyramid[top + t.x0]), uint(pyramid[top + t.x1]), uint(pyramid[bottom + t.x0]),
                      uint(pyramid[bottom + t.x1]));
}

// Pixel (x, y) of level k = s + 2: from the four level-(s + 1) pixels its taps name.
uint two_below(int k, int x, int y) {
  const ResizeTaps t = resize_taps(p.table_offset[k], p.planes.level[k - 1], p.planes.level[k], x, y);
  return resize_value(t, from_source(k - 1, t.x0, t.y0), from_source(k - 1, t.x1, t.y0),
                      from_source(k - 1, t.x0, t.y1), from_source(k - 1, t.x1, t.y1));
}

// Pixel (x, y) of level k = s + 3.
uint three_below(int k, int x, int y) {
  const ResizeTaps t = resize_taps(p.table_offset[k], p.planes.level[k - 1], p.planes.level[k], x, y);
  return resize_value(t, two_below(k - 1, t.x0, t.y0), two_below(k - 1, t.x1, t.y0), two_below(k - 1, t.x0, t.y1),
                      two_below(k - 1, t.x1, t.y1));
}

void main() {
  const int i = int(porta_linear_index());
  if (i >= p.first_pixel[p.last + 1]) return;
  int k = p.source + 1;
  while (i >= p.first_pixel[k + 1]) ++k;
  const Plane level = p.planes.level[k];
  const int j = i - p.first_pixel[k];
  const int y = j / level.width, x = j - y * level.width;
  const int depth = k - p.source;
  const uint v = depth == 1 ? from_source(k, x, y) : depth == 2 ? two_below(k, x, y) : three_below(k, x, y);
  pyramid[level.offset_bytes + y * level.pitch + x] = uint8_t(v);
}
