#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.3 FAST CRF with bounded rectification (DESIGN.md §3.3, backends/cpu/detect_kernels.cpp): one
// invocation per pixel of every level, the rows of all levels laid end to end (global: widest
// level x total rows). Response = sum |I_i - c| over the circle when lut[bright] | lut[dark], else
// 0; pixels within `edge` of the border get 0, so every pixel of the level is written.
layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Lut { uint8_t lut[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Responses { uint16_t responses[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels src;  // empty levels have width = height = 0
  Levels dst;
  int eps;
  int edge;
} p;

// The radius-3 Bresenham circle (tables.hpp kFastCircle), clockwise from 12 o'clock.
const int kDx[16] = int[16](0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3, -3, -3, -2, -1);
const int kDy[16] = int[16](-3, -3, -2, -1, 0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3);

void main() {
  const int x = int(gl_GlobalInvocationID.x);
  int row = int(gl_GlobalInvocationID.y);
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
  if (x >= d.width) return;
  uint response = 0u;
  if (y >= p.edge && y < s.height - p.edge && x >= p.edge && x < s.width - p.edge) {
    const int centre = s.offset_bytes + y * s.pitch + x;
    const int c = int(pyramid[centre]);
    uint bright = 0u, dark = 0u;
    int sum = 0;
    for (int i = 0; i < 16; ++i) {
      const int q = int(pyramid[centre + kDy[i] * s.pitch + kDx[i]]);
      // Two independent tests, as in the contract.
      if (q > c + p.eps) bright |= 1u << i;
      if (q < c - p.eps) dark |= 1u << i;
      sum += abs(q - c);
    }
    if ((uint(lut[bright]) | uint(lut[dark])) != 0u) response = uint(sum);  // <= 4080
  }
  // Response planes hold 2-byte elements: offset_bytes is even (checked on the host).
  responses[d.offset_bytes / 2 + y * d.pitch + x] = uint16_t(response);
}
