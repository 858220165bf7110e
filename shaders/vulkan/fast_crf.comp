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

#include "fast_common.glsl"

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
  if (y >= p.edge && y < s.height - p.edge && x >= p.edge && x < s.width - p.edge)
    response = fast_response(s.offset_bytes + y * s.pitch + x, s.pitch, p.eps);
  // Response planes hold 2-byte elements: offset_bytes is even (checked on the host).
  responses[d.offset_bytes / 2 + y * d.pitch + x] = uint16_t(response);
}
