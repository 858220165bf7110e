#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.2 pyramid on GPUs, levels 1..count-1 in one dispatch without repeated work: one workgroup per
// 32 x 8 tile of those levels, each pixel computed once, exactly as build_pyramid_wide.comp does.
// A tile of level n reads a region of level n - 1 that other workgroups of the same dispatch
// write, so it waits for them:
//  * Workgroups take the tiles in the order of a ticket (an atomic counter), not of their IDs, and
//    tiles are numbered level by level: a tile waits only for tiles of lower numbers, whose
//    workgroups have already started. A GPU that runs the workgroups it started side by side
//    (NVIDIA's: the backend's default there) then finishes them, whatever order or how many at a
//    time it starts them in. Vulkan does not promise that: lavapipe (Mesa 22.3) with several
//    threads left waiting workgroups unfinished, so the suite checks this kernel there with one
//    thread (each workgroup then runs to its end before the next takes a ticket).
//  * Every invocation adds 1 to its tile's count after writing its pixel (after a buffer memory
//    barrier of its own): a tile is done when its count is its pixel count. A waiting tile polls
//    the counts of the tiles its region overlaps (at most 3 x 3: the region is ~1.2x the tile
//    plus one pixel), one invocation each, then reads the pixels after a memory barrier and a
//    workgroup barrier. The pyramid buffer is coherent, so the reads see the other workgroups'
//    writes rather than a stale cache.
//  * Counts are read by atomicCompSwap(c, v, v): a read that is an atomic operation everywhere.
//    Every invocation signals its own pixel, rather than one invocation the whole tile after a
//    barrier: GLSL's memoryBarrierBuffer() orders an invocation's own accesses only.
//  * The last workgroup to finish (all have taken their tickets) zeroes the counts, the ticket and
//    the count of finished workgroups, so the next dispatch on the same control buffer (the backend
//    keeps one per queue; barriers order the dispatches that share it) starts clean.
// Control buffer: [0] ticket, [1] finished workgroups, [2 + t] tile t's count (zero when made).
layout(local_size_x = PORTA_TILE_W, local_size_y = PORTA_TILE_H) in;

layout(std430, set = 0, binding = 0) coherent buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Table { int table[]; };
layout(std430, set = 0, binding = 2) coherent buffer Control { uint control[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels planes;  // every level (level 0 is read, levels 1..count-1 written)
  Tiles tiles;    // tiles of levels 1..count-1 only (level 0 has none)
  int table_offset[PORTA_MAX_LEVELS];  // of level n's tables at [n] (ResizeTables::level_offset[n - 1])
} p;

#include "resize_taps.glsl"

shared int ticket_of_group;
shared bool last_group;

// Pixels in tile (tx, ty) of a plane: 32 x 8 but at the right and bottom edges.
uint tile_pixels(Plane plane, int tx, int ty) {
  return uint(min(PORTA_TILE_W, plane.width - tx * PORTA_TILE_W) * min(PORTA_TILE_H, plane.height - ty * PORTA_TILE_H));
}

void main() {
  const uint tid = gl_LocalInvocationIndex;
  if (tid == 0u) ticket_of_group = int(atomicAdd(control[0], 1u));
  barrier();
  const int tile = ticket_of_group;
  int n;
  ivec2 origin;
  PORTA_TILE_OF(p.tiles, p.planes.count, tile, n, origin);

  if (n >= 1) {  // the whole workgroup: n comes from shared memory
    const Plane above = p.planes.level[n - 1];
    const Plane level = p.planes.level[n];
    if (n >= 2) {
      // The region of level n - 1 the tile reads (the tables' source indices never decrease), and
      // the tiles of level n - 1 it overlaps.
      const int cols = p.table_offset[n];
      const int rows = cols + 2 * level.width;
      const int xa = table[cols + origin.x];
      const int xb = min(table[cols + min(origin.x + PORTA_TILE_W, level.width) - 1] + 1, above.width - 1);
      const int ya = table[rows + origin.y];
      const int yb = min(table[rows + min(origin.y + PORTA_TILE_H, level.height) - 1] + 1, above.height - 1);
      const int tx0 = xa / PORTA_TILE_W, ty0 = ya / PORTA_TILE_H;
      const int across = xb / PORTA_TILE_W - tx0 + 1;
      const int needed = across * (yb / PORTA_TILE_H - ty0 + 1);
      if (int(tid) < needed) {
        const int tx = tx0 + int(tid) % across, ty = ty0 + int(tid) / across;
        const int t = p.tiles.first[n - 1] + ty * p.tiles.across[n - 1] + tx;
        const uint full = tile_pixels(above, tx, ty);
        while (atomicCompSwap(control[2 + t], full, full) != full) {
        }
      }
      memoryBarrierBuffer();
    }
    barrier();
    const int x = origin.x + int(gl_LocalInvocationID.x), y = origin.y + int(gl_LocalInvocationID.y);
    if (x < level.width && y < level.height) {
      const ResizeTaps t = resize_taps(p.table_offset[n], above, level, x, y);
      const int top = above.offset_bytes + t.y0 * above.pitch;
      const int bottom = above.offset_bytes + t.y1 * above.pitch;
      pyramid[level.offset_bytes + y * level.pitch + x] =
          uint8_t(resize_value(t, uint(pyramid[top + t.x0]), uint(pyramid[top + t.x1]),
                               uint(pyramid[bottom + t.x0]), uint(pyramid[bottom + t.x1])));
      memoryBarrierBuffer();
      atomicAdd(control[2 + tile], 1u);
    }
  }

  const uint groups = gl_NumWorkGroups.x * gl_NumWorkGroups.y * gl_NumWorkGroups.z;
  barrier();  // every invocation's count added before the workgroup counts as finished
  if (tid == 0u) {
    memoryBarrierBuffer();
    last_group = atomicAdd(control[1], 1u) == groups - 1u;
  }
  barrier();
  if (last_group) {  // every workgroup has taken its ticket and finished
    for (int i = int(tid); i < p.tiles.first[p.planes.count]; i += PORTA_TILE_W * PORTA_TILE_H) control[2 + i] = 0u;
    if (tid == 0u) {
      control[0] = 0u;
      control[1] = 0u;
    }
  }
}
