#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "list_common.glsl"

// §3.6 orientation for CPU devices (lavapipe), where a workgroup per keypoint (orient.comp) costs
// more than it saves (DESIGN.md §3.6, backends/cpu/describe_kernels.cpp): one invocation per list
// slot, launched over the capacity; the same bytes as orient.comp. Keypoint i gets angle_bin from the moments m10 = sum dx * I,
// m01 = sum dy * I over the disc |dy| <= 15, |dx| <= umax[|dy|] of its unblurred level: the first
// bin b with cross(u_b, m) >= 0 > cross(u_{b+1 mod B}, m), bin 0 when none. The other fields are
// kept. A keypoint the cpu backend refuses (level outside the pyramid, closer than 15 px to the
// border) is left unchanged. Integer sums: the result does not depend on the order of the adds.
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) buffer Keypoints { uvec2 keypoints[]; };
layout(std430, set = 0, binding = 2) readonly buffer Count { uint8_t count_bytes[]; };
layout(std430, set = 0, binding = 3) readonly buffer Boundaries { int boundaries[]; };  // (x, y) per bin
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  int umax[16];
  int capacity;
  uint count_offset;
  int bins;
} p;

#define ORIENT_RADIUS 15

void main() {
  const uint i = porta_linear_index();
  if (i >= uint(PORTA_LIST_LENGTH(count_bytes, p.count_offset, p.capacity))) return;
  const uvec2 kp = keypoints[i];
  const int level = int(kp_level(kp));
  if (level >= p.layout_.count) return;
  const Plane plane = p.layout_.level[level];
  const int x = int(kp_x(kp)), y = int(kp_y(kp));
  if (x < ORIENT_RADIUS || y < ORIENT_RADIUS || x + ORIENT_RADIUS >= plane.width ||
      y + ORIENT_RADIUS >= plane.height)
    return;
  const int centre = plane.offset_bytes + y * plane.pitch + x;
  // |m| < 2^20 (255 * sum of |dx| over the half disc): int holds both moments.
  int m10 = 0, m01 = 0;
  for (int dy = -ORIENT_RADIUS; dy <= ORIENT_RADIUS; ++dy) {
    const int row = centre + dy * plane.pitch;
    const int half_width = p.umax[abs(dy)];
    int row_sum = 0;
    for (int dx = -half_width; dx <= half_width; ++dx) {
      const int v = int(uint(pyramid[row + dx]));
      row_sum += v;
      m10 += dx * v;
    }
    m01 += dy * row_sum;
  }
  // cross(u, m) = u.x * m01 - u.y * m10 (contract_math.hpp orientation_cross; |u| <= 1024: int32).
  int bin = 0;
  for (int b = 0; b < p.bins; ++b) {
    const int next = b + 1 == p.bins ? 0 : b + 1;
    const int cross_b = boundaries[2 * b] * m01 - boundaries[2 * b + 1] * m10;
    const int cross_next = boundaries[2 * next] * m01 - boundaries[2 * next + 1] * m10;
    if (cross_b >= 0 && cross_next < 0) {
      bin = b;
      break;
    }
  }
  keypoints[i] = uvec2(kp.x, (kp.y & 0x00FFFFFFu) | (uint(bin) << 24));
}
