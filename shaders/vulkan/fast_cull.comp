#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"

// §3.3 and §3.4 fused on GPUs (the backend's detect_keypoints): FAST (fast_crf.comp's test) on the
// cells' pixels straight from the pyramid, each cell's maximum kept, no response plane between them.
// The work split is checks::CellGroups, in the grid's first_group and group_shift: a 256-wide
// workgroup holds 256 >> group_shift cells of one level, 1 << group_shift invocations each (a
// 32 x 32 cell takes the whole workgroup, four pixels per invocation; 8 x 8 cells sixteen to a
// workgroup; a workgroup of one cell reads it with its halo into shared memory first). The key (response << 32) | ~(row-major index in the cell) and its maximum are
// cull_cells.comp's, reduced through shared memory (no subgroup operations, so any subgroup size
// gives the same bytes); pixels within `edge` of the border have response 0, as fast_crf gives
// them. The same cell records as fast_crf then cull_cells.
#define GROUP 256
layout(local_size_x = GROUP) in;

layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Lut { uint8_t lut[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Out { uvec2 cells_out[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  Cells cells;
  int eps;
  int edge;
  int pad0;
  int pad1;
} p;

#include "fast_common.glsl"

shared uint64_t best[GROUP];

// A workgroup with one cell of at most TILE_CAP pixels with its 3-pixel halo reads them into shared
// memory first (one round of independent loads, clamped to the level: a pixel whose circle leaves
// the level is within `edge` >= 3 of its border and is not tested), then tests its pixels there.
#define TILE_CAP 2304
shared int tile[TILE_CAP];

// fast_response (fast_common.glsl) on the tile, `centre` an index into it, rows `tw` apart.
uint tile_response(int centre, int tw, int eps) {
  const int c = tile[centre];
  uint bright = 0u, dark = 0u;
  int sum = 0;
  for (int i = 0; i < 16; ++i) {
    const int q = tile[centre + kDy[i] * tw + kDx[i]];
    if (q > c + eps) bright |= 1u << i;
    if (q < c - eps) dark |= 1u << i;
    sum += abs(q - c);
  }
  return (uint(lut[bright]) | uint(lut[dark])) != 0u ? uint(sum) : 0u;
}

void main() {
  const int group = int(porta_linear_group());
  int n = 0;  // the last level whose workgroups start at or before this one (empty levels have none)
  for (int i = 1; i < p.cells.count; ++i)
    if (group >= p.cells.level[i].first_group) n = i;
  const LevelCells grid = p.cells.level[n];
  const Plane s = p.layout_.level[n];
  const int shift = grid.group_shift;  // uniform over the workgroup
  const int lid = int(gl_LocalInvocationID.x);
  const int slot = lid >> shift, lane = lid & ((1 << shift) - 1);
  const int index = (group - grid.first_group) * (GROUP >> shift) + slot;
  const bool in_grid = index < grid.cols * grid.rows;

  uint64_t key = 0ul;
  int x0 = 0, y0 = 0, w = 1, h = 0;
  if (in_grid) {
    const int cell_y = index / grid.cols;
    const int cell_x = index - cell_y * grid.cols;
    y0 = cell_y * grid.cell_h;
    x0 = cell_x * grid.cell_w;
    w = min(x0 + grid.cell_w, s.width) - x0;
    h = min(y0 + grid.cell_h, s.height) - y0;
  }
  // Uniform: a workgroup of one cell (then in_grid everywhere) whose region fits the tile.
  if ((GROUP >> shift) == 1 && (grid.cell_w + 6) * (grid.cell_h + 6) <= TILE_CAP) {
    const int tw = w + 6;
    for (int k = lid; k < tw * (h + 6); k += GROUP) {
      const int r = k / tw, c = k - r * tw;
      const int sy = clamp(y0 - 3 + r, 0, s.height - 1);
      const int sx = clamp(x0 - 3 + c, 0, s.width - 1);
      tile[k] = int(pyramid[s.offset_bytes + sy * s.pitch + sx]);
    }
    barrier();
    for (int i = lid; i < w * h; i += GROUP) {
      const int dy = i / w;
      const int dx = i - dy * w;
      const int x = x0 + dx, y = y0 + dy;
      if (y < p.edge || y >= s.height - p.edge || x < p.edge || x >= s.width - p.edge) continue;
      const uint r = tile_response((dy + 3) * tw + dx + 3, tw, p.eps);
      const uint64_t k = (uint64_t(r) << 32) | uint64_t(0xFFFFFFFFu - uint(i));
      key = r > 0u && k > key ? k : key;
    }
  } else if (in_grid) {
    for (int i = lane; i < w * h; i += 1 << shift) {
      const int dy = i / w;
      const int x = x0 + i - dy * w, y = y0 + dy;
      if (y < p.edge || y >= s.height - p.edge || x < p.edge || x >= s.width - p.edge) continue;
      const uint r = fast_response(s.offset_bytes + y * s.pitch + x, s.pitch, p.eps);
      const uint64_t k = (uint64_t(r) << 32) | uint64_t(0xFFFFFFFFu - uint(i));
      key = r > 0u && k > key ? k : key;
    }
  }
  // Each cell's invocations are contiguous: a tree over the lanes of every slot at once.
  best[lid] = key;
  barrier();
  for (int stride = (1 << shift) >> 1; stride > 0; stride >>= 1) {
    if (lane < stride) {
      const uint64_t other = best[lid + stride];
      if (other > best[lid]) best[lid] = other;
    }
    barrier();
  }
  if (lane == 0 && in_grid) {
    const uint64_t k = best[lid];
    const uint r = uint(k >> 32);
    uvec2 kp = uvec2(0u);
    if (r > 0u) {
      const int i = int(0xFFFFFFFFu - uint(k & 0xFFFFFFFFul));
      kp = make_keypoint(uint(x0 + i % w), uint(y0 + i / w), r, uint(n), 0u);
    }
    cells_out[grid.first_cell + index] = kp;
  }
}
