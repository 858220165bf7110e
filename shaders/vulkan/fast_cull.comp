#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"

// §3.3 and §3.4 fused on GPUs (the backend's detect_keypoints): one workgroup per cell of every
// level computes FAST (fast_crf.comp's test) on the cell's pixels straight from the pyramid and
// keeps their maximum, with no response plane between them. The key (response << 32) |
// ~(row-major index in the cell) and the reduction are cull_cells.comp's; pixels within `edge` of
// the border have response 0, as fast_crf gives them. The same cell records as fast_crf then
// cull_cells.
layout(local_size_x = 64) in;

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

#include "cull_common.glsl"

#include "fast_common.glsl"

void main() {
  const int cell = int(porta_linear_group());
  const int n = cull_level_of(cell);
  if (n < 0) return;  // the whole workgroup: `cell` is uniform
  const LevelCells grid = p.cells.level[n];
  const Plane s = p.layout_.level[n];
  const int index = cell - grid.first_cell;
  const int cell_y = index / grid.cols;
  const int cell_x = index - cell_y * grid.cols;
  const int y0 = cell_y * grid.cell_h;
  const int x0 = cell_x * grid.cell_w;
  const int w = min(x0 + grid.cell_w, s.width) - x0;
  const int h = min(y0 + grid.cell_h, s.height) - y0;

  const uint lid = gl_LocalInvocationID.x;
  uint64_t key = 0ul;
  for (int i = int(lid); i < w * h; i += 64) {
    const int dy = i / w;
    const int x = x0 + i - dy * w, y = y0 + dy;
    if (y < p.edge || y >= s.height - p.edge || x < p.edge || x >= s.width - p.edge) continue;
    const uint r = fast_response(s.offset_bytes + y * s.pitch + x, s.pitch, p.eps);
    const uint64_t k = (uint64_t(r) << 32) | uint64_t(0xFFFFFFFFu - uint(i));
    key = r > 0u && k > key ? k : key;
  }
  cull_write_maximum(key, cell, x0, y0, w, n);
}
