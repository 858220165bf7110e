#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
#include "list_common.glsl"

// §3.8 ORB descriptor (DESIGN.md §3.8, backends/cpu/describe_kernels.cpp): one invocation per
// (list slot, 32-bit word of its descriptor), launched over capacity * 8. Bit j of descriptor i is
// I(p + a_j) < I(p + b_j) on the blurred level with the j-th pair of the keypoint's angle bin,
// stored at byte j / 8, bit j % 8, i.e. bit j % 32 of little-endian word j / 32. The pattern is
// bins * 256 pairs of int8 (ax, ay, bx, by): one 32-bit word per pair, its bytes sign-extended
// with bitfieldExtract. A keypoint the cpu backend refuses (level outside the pyramid, closer
// than 18 px to the border, angle bin outside the table) leaves its descriptor slot unchanged.
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Blurred { uint8_t blurred[]; };
layout(std430, set = 0, binding = 1) readonly buffer Keypoints { uvec2 keypoints[]; };
layout(std430, set = 0, binding = 2) readonly buffer Count { uint8_t count_bytes[]; };
layout(std430, set = 0, binding = 3) readonly buffer Pattern { uint pattern[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Descriptors { uint descriptors[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  int capacity;
  uint count_offset;
  int bins;
} p;

#define ORB_REACH 18

void main() {
  const uint gid = porta_linear_index();
  const uint i = gid >> 3;
  const uint word = gid & 7u;
  if (i >= uint(PORTA_LIST_LENGTH(count_bytes, p.count_offset, p.capacity))) return;
  const uvec2 kp = keypoints[i];
  const int level = int(kp_level(kp));
  if (level >= p.layout_.count || int(kp_angle_bin(kp)) >= p.bins) return;
  const Plane plane = p.layout_.level[level];
  const int x = int(kp_x(kp)), y = int(kp_y(kp));
  if (x < ORB_REACH || y < ORB_REACH || x + ORB_REACH >= plane.width || y + ORB_REACH >= plane.height) return;
  const int centre = plane.offset_bytes + y * plane.pitch + x;
  const uint first = kp_angle_bin(kp) * 256u + word * 32u;
  uint bits = 0u;
  for (uint b = 0u; b < 32u; ++b) {
    const int pair = int(pattern[first + b]);
    const int ax = bitfieldExtract(pair, 0, 8), ay = bitfieldExtract(pair, 8, 8);
    const int bx = bitfieldExtract(pair, 16, 8), by = bitfieldExtract(pair, 24, 8);
    const uint a = uint(blurred[centre + ay * plane.pitch + ax]);
    const uint c = uint(blurred[centre + by * plane.pitch + bx]);
    bits |= uint(a < c) << b;
  }
  descriptors[i * 8u + word] = bits;
}
