#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"

// §3.4 feature culling for small cells (at most kSmallCellPixels, detect_kernels.cpp): one
// invocation per cell scans it alone, so a grid of many tiny cells costs no workgroup barriers
// (on lavapipe a barrier-synchronised workgroup per 2x2 cell made an 8000x40 image take 27 s).
// The same key as cull_cells.comp, (response << 32) | ~(row-major index in the cell), and the
// same maximum: the bytes are those of cull_cells.comp and of the cpu backend.
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

  uint64_t key = 0ul;
  for (int i = 0; i < w * h; ++i) {
    const int dy = i / w;
    const int dx = i - dy * w;
    const uint r = uint(responses[base + dy * plane.pitch + dx]);
    const uint64_t k = (uint64_t(r) << 32) | uint64_t(0xFFFFFFFFu - uint(i));
    key = k > key ? k : key;
  }
  const uint r = uint(key >> 32);
  uvec2 kp = uvec2(0u);
  if (r > 0u) {
    const int i = int(0xFFFFFFFFu - uint(key & 0xFFFFFFFFul));
    kp = make_keypoint(uint(x0 + i % w), uint(y0 + i / w), r, uint(n), 0u);
  }
  cells_out[cell] = kp;
}
