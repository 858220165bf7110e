#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#include "list_common.glsl"
#include "stereo_common.glsl"

// §3.9 stereo matching, step f (DESIGN.md §3.9, backends/cpu/match_kernels.cpp): one workgroup.
// Invocation 0 finds the median, the accepted SAD at index count / 2 in ascending order, by
// walking the coarse then the fine histogram (-1 when no match was accepted); then every
// invocation drops the accepted matches of its slots (stride 256) whose SAD exceeds 2.1x the
// median: sad * 10 > 21 * median in 64 bits (contract_math.hpp sad_is_outlier).
layout(local_size_x = 256) in;

layout(std430, set = 0, binding = 0) readonly buffer LeftCount { uint8_t left_count[]; };
layout(std430, set = 0, binding = 1) readonly buffer Sads { int sads[]; };
layout(std430, set = 0, binding = 2) buffer Histogram { uint histogram[]; };
layout(std430, set = 0, binding = 3) buffer Matches { ivec2 matches[]; };
layout(std430, push_constant) uniform Params {
  int left_capacity;
  uint left_count_offset;
} p;

shared int median;

void main() {
  const uint lid = gl_LocalInvocationID.x;
  if (lid == 0u) {
    uint total = 0u;
    for (int b = 0; b < STEREO_SAD_BLOCKS; ++b) total += histogram[STEREO_HIST_COARSE + b];
    int m = -1;
    if (total > 0u) {
      const uint k = total / 2u;
      uint below = 0u;
      int block = 0;
      while (below + histogram[STEREO_HIST_COARSE + block] <= k)
        below += histogram[STEREO_HIST_COARSE + block++];
      int value = block * 256;
      while (below + histogram[value] <= k) below += histogram[value++];
      m = value;
    }
    median = m;
    histogram[STEREO_HIST_MEDIAN] = uint(m);  // for inspection only
  }
  barrier();
  const int m = median;
  if (m < 0) return;
  const uint n = uint(PORTA_LIST_LENGTH(left_count, p.left_count_offset, p.left_capacity));
  for (uint i = lid; i < n; i += 256u) {
    const int sad = sads[i];
    if (sad >= 0 && int64_t(sad) * 10l > int64_t(m) * 21l) matches[i] = ivec2(-1);
  }
}
