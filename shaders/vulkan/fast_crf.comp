#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.3 FAST CRF with bounded rectification (DESIGN.md §3.3, backends/cpu/detect_kernels.cpp) for
// CPU devices (lavapipe): one invocation per row of every level, the rows of all levels laid end
// to end (Work::items(total rows)), walking the row with the circle's offsets fixed. Response =
// sum |I_i - c| over the circle when lut[bright] | lut[dark], else 0; pixels within `edge` of the
// border get 0, so every pixel of the level is written.
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Lut { uint8_t lut[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Responses { uint16_t responses[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels src;  // empty levels have width = height = 0
  Levels dst;
  int eps;
  int edge;
} p;

#include "fast_common.glsl"

void main() {
  int row = int(porta_linear_index());
  int n = -1;
  for (int i = 0; i < p.src.count; ++i) {
    if (row < p.src.level[i].height) {
      n = i;
      break;
    }
    row -= p.src.level[i].height;
  }
  if (n < 0) return;
  const int y = row;
  const Plane s = p.src.level[n];
  const Plane d = p.dst.level[n];
  const int eps = p.eps, edge = p.edge;
  // Response planes hold 2-byte elements: offset_bytes is even (checked on the host).
  const int base = d.offset_bytes / 2 + y * d.pitch;
  const bool row_inside = y >= edge && y < s.height - edge;
  const int x_begin = row_inside ? min(max(edge, 0), d.width) : d.width;
  const int x_end = row_inside ? max(x_begin, min(s.width - edge, d.width)) : d.width;
  for (int x = 0; x < x_begin; ++x) responses[base + x] = uint16_t(0);
  for (int x = x_end; x < d.width; ++x) responses[base + x] = uint16_t(0);
  int offset[16];
  for (int i = 0; i < 16; ++i) offset[i] = kDy[i] * s.pitch + kDx[i];
  const int centre_row = s.offset_bytes + y * s.pitch;
  for (int x = x_begin; x < x_end; ++x) {
    const int centre = centre_row + x;
    const int c = int(pyramid[centre]);
    uint bright = 0u, dark = 0u;
    int sum = 0;
    for (int i = 0; i < 16; ++i) {
      const int q = int(pyramid[centre + offset[i]]);
      bright |= uint(q > c + eps) << i;
      dark |= uint(q < c - eps) << i;
      sum += abs(q - c);
    }
    responses[base + x] = uint16_t((uint(lut[bright]) | uint(lut[dark])) != 0u ? uint(sum) : 0u);
  }
}
