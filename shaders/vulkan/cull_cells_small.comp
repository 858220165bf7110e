#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.4 feature culling for small cells (at most kSmallCellPixels, detect_kernels.cpp): one
// invocation per cell scans it alone, so a grid of many tiny cells costs no workgroup barriers
// (on lavapipe a barrier-synchronised workgroup per 2x2 cell made an 8000x40 image take 27 s).
// cull_cells.comp takes the maximum of the key (response << 32) | ~(row-major index in the cell);
// a row-major scan keeping a strictly larger response finds the same pixel: the bytes are those of
// cull_cells.comp and of the cpu backend. Also the culling of any cells on CPU devices (lavapipe).
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Responses { uint16_t responses[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Out { uvec2 cells_out[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  Cells cells;
  int end_cell;
} p;

void main() {
  const int cell = int(porta_linear_index());
  if (cell >= p.end_cell) return;
  int n = -1;
  for (int i = 0; i < p.cells.count; ++i) {
    const LevelCells c = p.cells.level[i];
    if (cell >= c.first_cell && cell - c.first_cell < c.cols * c.rows) {
      n = i;
      break;
    }
  }
  if (n < 0) return;
  const LevelCells grid = p.cells.level[n];
  const Plane plane = p.layout_.level[n];
  const int index = cell - grid.first_cell;
  const int cell_y = index / grid.cols;
  const int cell_x = index - cell_y * grid.cols;
  const int y0 = cell_y * grid.cell_h;
  const int x0 = cell_x * grid.cell_w;
  const int w = min(x0 + grid.cell_w, plane.width) - x0;
  const int h = min(y0 + grid.cell_h, plane.height) - y0;
  const int base = plane.offset_bytes / 2 + y0 * plane.pitch + x0;

  // Row-major with a strict '>': the largest response at the smallest index, the maximum of the key.
  uint r = 0u;
  int best_x = 0, best_y = 0;
  for (int dy = 0; dy < h; ++dy) {
    const int row = base + dy * plane.pitch;
    for (int dx = 0; dx < w; ++dx) {
      const uint v = uint(responses[row + dx]);
      if (v > r) {
        r = v;
        best_x = dx;
        best_y = dy;
      }
    }
  }
  uvec2 kp = uvec2(0u);
  if (r > 0u) kp = make_keypoint(uint(x0 + best_x), uint(y0 + best_y), r, uint(n), 0u);
  cells_out[cell] = kp;
}
