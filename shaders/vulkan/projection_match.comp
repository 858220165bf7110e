#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "common.glsl"
#include "list_common.glsl"

// §3.10 projection matching (DESIGN.md §3.10, backends/cpu/match_kernels.cpp): one workgroup per
// query. Candidates are the keypoints with level in [min_level, max_level] (and a scale: level <
// num_scales) within the inclusive square window of radius r around (u, v) at level 0
// (|pos_q8 - u| <= r, |pos_q8 - v| <= r in 64 bits). The invocations scan the list with stride 64,
// each keeping (best = distance << 32 | index, second = smallest distance of its other
// candidates); two such states merge into (min(best, best'), min(second, second', distance of the
// larger best)), which is associative and commutative, so the shared-memory tree (no subgroup
// operations) gives the cpu's "smallest distance, ties to the lower index" and the smallest
// distance among the other candidates whatever the order. 256 / -1 when there is none.
// Scales of levels >= 12 (never a pyramid level) come from `more_scales`.
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Keypoints { uvec2 keypoints[]; };
layout(std430, set = 0, binding = 1) readonly buffer Count { uint8_t count_bytes[]; };
layout(std430, set = 0, binding = 2) readonly buffer KeypointDescriptors { uint kp_desc[]; };
layout(std430, set = 0, binding = 3) readonly buffer Queries { ivec4 queries[]; };  // ProjectionQuery
layout(std430, set = 0, binding = 4) readonly buffer QueryDescriptors { uint query_desc[]; };
layout(std430, set = 0, binding = 5) readonly buffer MoreScales { int more_scales[]; };
layout(std430, set = 0, binding = 6) writeonly buffer Results { ivec4 results[]; };  // ProjectionResult
layout(std430, push_constant) uniform Params {
  int capacity;
  uint count_offset;
  int num_queries;
  int num_scales;
  int scales[PORTA_MAX_LEVELS];
} p;

#define GROUP 64u
#define NO_CANDIDATE ((uint64_t(256u) << 32) | uint64_t(0xFFFFFFFFu))

shared uint64_t best_key[GROUP];
shared uint second_distance[GROUP];

void main() {
  const uint q = porta_linear_group();  // uniform over the workgroup
  const uint lid = gl_LocalInvocationID.x;
  if (q >= uint(p.num_queries)) return;
  const int n = PORTA_LIST_LENGTH(count_bytes, p.count_offset, p.capacity);
  const ivec4 query = queries[q];
  const int64_t u = int64_t(query.x), v = int64_t(query.y), r = int64_t(query.z);
  const uint min_level = uint(query.w) & 0xFFu, max_level = (uint(query.w) >> 8) & 0xFFu;
  uint d[8];
  for (uint w = 0u; w < 8u; ++w) d[w] = query_desc[q * 8u + w];

  uint64_t best = NO_CANDIDATE;
  uint second = 256u;
  for (uint k = lid; k < uint(n); k += GROUP) {
    const uvec2 kp = keypoints[k];
    const uint level = kp_level(kp);
    if (int(level) >= p.num_scales || level < min_level || level > max_level) continue;
    const int s =
        level < uint(PORTA_MAX_LEVELS) ? p.scales[level] : more_scales[level - uint(PORTA_MAX_LEVELS)];
    const int64_t dv = int64_t(porta_level0_q8(kp_y(kp), s)) - v;
    const int64_t du = int64_t(porta_level0_q8(kp_x(kp), s)) - u;
    if (dv < -r || dv > r || du < -r || du > r) continue;
    uint distance = 0u;
    for (uint w = 0u; w < 8u; ++w) distance += uint(bitCount(d[w] ^ kp_desc[k * 8u + w]));
    const uint64_t key = (uint64_t(distance) << 32) | uint64_t(k);
    // The displaced best (256 when there was none) is now a runner-up.
    second = min(second, uint(max(best, key) >> 32));
    best = min(best, key);
  }
  best_key[lid] = best;
  second_distance[lid] = second;
  barrier();
  for (uint stride = GROUP / 2u; stride > 0u; stride >>= 1) {
    if (lid < stride) {
      const uint64_t a = best_key[lid], b = best_key[lid + stride];
      second_distance[lid] =
          min(min(second_distance[lid], second_distance[lid + stride]), uint(max(a, b) >> 32));
      best_key[lid] = min(a, b);
    }
    barrier();
  }
  if (lid == 0u) {
    const uint64_t b = best_key[0];
    const int index = b == NO_CANDIDATE ? -1 : int(uint(b & 0xFFFFFFFFul));
    results[q] = ivec4(index, int(b >> 32), int(second_distance[0]), 0);
  }
}
