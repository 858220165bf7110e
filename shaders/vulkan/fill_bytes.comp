#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// Backend::fill for the bytes outside whole aligned words (vkCmdFillBuffer does the words):
// data[offset + i] = value for i < count. One invocation per byte.
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) writeonly buffer Data { uint8_t data[]; };
layout(std430, push_constant) uniform Params {
  uint offset;
  uint count;
  uint value;
} p;

void main() {
  const uint i = porta_linear_index();
  if (i >= p.count) return;
  data[p.offset + i] = uint8_t(p.value);
}
