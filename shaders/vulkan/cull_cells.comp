#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"

// §3.4 feature culling (DESIGN.md §3.4, backends/cpu/detect_kernels.cpp): one workgroup per cell
// of every level. Each invocation scans a strided share of the cell, then the workgroup reduces
// through shared memory; no subgroup operations, so the bytes do not depend on the subgroup size.
// The reduction key (response << 32) | ~(row-major index in the cell) makes the maximum the
// largest response with ties to the smaller row, then column, whatever the order of the
// comparisons. An all-zero record when the maximum is 0.
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Responses { uint16_t responses[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Out { uvec2 cells_out[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  Cells cells;
} p;

#include "cull_common.glsl"

void main() {
  const int cell = int(porta_linear_group());
  const int n = cull_level_of(cell);
  if (n < 0) return;  // the whole workgroup: `cell` is uniform
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

  const uint lid = gl_LocalInvocationID.x;
  uint64_t key = 0ul;
  for (int i = int(lid); i < w * h; i += 64) {
    const int dy = i / w;
    const int dx = i - dy * w;
    const uint r = uint(responses[base + dy * plane.pitch + dx]);
    const uint64_t k = (uint64_t(r) << 32) | uint64_t(0xFFFFFFFFu - uint(i));
    key = k > key ? k : key;
  }
  cull_write_maximum(key, cell, x0, y0, w, n);
}
