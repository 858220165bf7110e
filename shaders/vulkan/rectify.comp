#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// §3.1 rectify (DESIGN.md §3.1, backends/cpu/image_kernels.cpp): one invocation per destination
// pixel; bilinear sample of `src` at the Q5 map position (xq, yq): 5-bit weights,
// (sum w * p + 512) >> 10, taps outside the source read 0. GLSL's >> on int is arithmetic, so
// xq >> 5 is a floor for negative xq too.
layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = 0) readonly buffer Src { uint8_t src[]; };
layout(std430, set = 0, binding = 1) readonly buffer Map { int map_q5[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Dst { uint8_t dst[]; };
layout(std430, push_constant) uniform Params {
  Plane sp;
  Plane dp;
} p;

uint tap(int x, int y) {
  if (x < 0 || y < 0 || x >= p.sp.width || y >= p.sp.height) return 0u;
  return uint(src[p.sp.offset_bytes + y * p.sp.pitch + x]);
}

void main() {
  const int x = int(gl_GlobalInvocationID.x);
  const int y = int(gl_GlobalInvocationID.y);
  if (x >= p.dp.width || y >= p.dp.height) return;
  const int m = (y * p.dp.width + x) * 2;
  const int xq = map_q5[m];
  const int yq = map_q5[m + 1];
  const int x0 = xq >> 5;
  const int y0 = yq >> 5;
  const uint fx = uint(xq & 31);
  const uint fy = uint(yq & 31);
  const uint sum = (32u - fx) * (32u - fy) * tap(x0, y0) + fx * (32u - fy) * tap(x0 + 1, y0) +
                   (32u - fx) * fy * tap(x0, y0 + 1) + fx * fy * tap(x0 + 1, y0 + 1);
  dst[p.dp.offset_bytes + y * p.dp.pitch + x] = uint8_t((sum + 512u) >> 10);
}
