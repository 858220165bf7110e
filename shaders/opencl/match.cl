// Stereo matching and projection matching kernels (DESIGN.md §3.9, §3.10; docs/ARCHITECTURE.md).
// The cpu backend (backends/cpu/match_kernels.cpp, stereo_math.hpp) defines the result; its row-
// bucketed searches equal the full scans in index order done here, by the explicit tie rules.

#define MATCH_SAD_HALF_WINDOW 5
#define MATCH_SAD_SEARCH 5
#define MATCH_SAD_SLOTS (2 * MATCH_SAD_SEARCH + 1)
// A centred SAD is at most 121 * 510; the median histogram has one bin per value, and a coarse one
// of 256-value blocks so that the single work-item finding the median walks few bins.
#define MATCH_SAD_VALUES 61711
#define MATCH_SAD_BLOCKS ((MATCH_SAD_VALUES + 255) / 256)
// Layout of the histogram scratch (uints): fine bins, coarse bins, then the median (as int).
#define MATCH_HIST_COARSE MATCH_SAD_VALUES
#define MATCH_HIST_MEDIAN (MATCH_SAD_VALUES + MATCH_SAD_BLOCKS)

// The length of a device list: the uint32 at count + offset (read bytewise, so any offset works),
// at most `capacity`.
inline int match_list_count(__global const uchar* count, long offset, int capacity) {
  if (capacity <= 0) return 0;  // an empty list need not have a count to read
  __global const uchar* p = count + offset;
  const uint n = (uint)p[0] | ((uint)p[1] << 8) | ((uint)p[2] << 16) | ((uint)p[3] << 24);
  return n < (uint)capacity ? (int)n : capacity;
}

// Level-0 position in 1/256 px: (c * S + 128) >> 8 in uint32 (stereo::level0_q8).
inline int match_level0_q8(int c, int scale_q16) {
  const uint p = (uint)c * (uint)scale_q16;
  return (int)((p + 128u) >> 8);
}

// Popcount of the XOR of two 256-bit descriptors (8 uints each).
inline int match_hamming(__global const uint* a, __global const uint* b) {
  int bits = 0;
  for (int w = 0; w < 8; ++w) bits += (int)popcount(a[w] ^ b[w]);
  return bits;
}

// Sum over the 11x11 window of |(L(p) - L(centre)) - (R(p + shift) - R(centre + shift))|.
inline int match_centred_sad(__global const uchar* left, __global const uchar* right, int pitch, int x_left,
                             int x_right, int y) {
  const int left_centre = left[(long)y * pitch + x_left];
  const int right_centre = right[(long)y * pitch + x_right];
  int sad = 0;
  for (int dy = -MATCH_SAD_HALF_WINDOW; dy <= MATCH_SAD_HALF_WINDOW; ++dy) {
    __global const uchar* lrow = left + (long)(y + dy) * pitch;
    __global const uchar* rrow = right + (long)(y + dy) * pitch;
    for (int dx = -MATCH_SAD_HALF_WINDOW; dx <= MATCH_SAD_HALF_WINDOW; ++dx) {
      const int diff = (lrow[x_left + dx] - left_centre) - (rrow[x_right + dx] - right_centre);
      sad += diff < 0 ? -diff : diff;
    }
  }
  return sad;
}

// Steps a-e of §3.9 for one left keypoint (stereo_match's match_left_keypoint); returns the SAD of
// the match, or -1 for "no match" (then *disparity and *right_index are not set).
// Steps a, b over the right keypoints first, first + step, ...: the candidate of smallest Hamming
// distance as the key (distance << 32) | index, whose minimum over any split of the list is the
// scan's "smallest distance, ties to the lower index"; ~0 for none.
inline ulong match_scan_right(const porta_levels* layout, porta_keypoint kl, __global const uint* left_descriptor,
                              __global const porta_keypoint* right, __global const uint* right_descriptors,
                              int first, int step, int num_right, const porta_level_ints* scales,
                              const porta_level_ints* radius, int min_disparity, int max_disparity) {
  const int levels = layout->count;
  const int nl = kl.level;
  ulong best = ~0ul;
  if (nl >= levels) return best;
  const int ul = match_level0_q8(kl.x, scales->v[nl]);
  const int vl = match_level0_q8(kl.y, scales->v[nl]);
  const int lo_level = max(0, nl - 1), hi_level = min(levels - 1, nl + 1);
  for (int j = first; j < num_right; j += step) {
    const porta_keypoint kr = right[j];
    if (kr.level < lo_level || kr.level > hi_level) continue;
    const int s = scales->v[kr.level];
    const long r = radius->v[kr.level];
    const long vr = match_level0_q8(kr.y, s);
    if (vr < (long)vl - r || vr > (long)vl + r) continue;
    const long d = (long)ul - match_level0_q8(kr.x, s);
    if (d < min_disparity || d > max_disparity) continue;
    const ulong key = ((ulong)match_hamming(left_descriptor, right_descriptors + (long)j * 8) << 32) | (uint)j;
    best = key < best ? key : best;
  }
  return best;
}

// Steps c-e for the left keypoint kl and the best candidate `best` of match_scan_right: its SAD
// (-1: no match) with *disparity and *right_index.
inline int match_refine(__global const uchar* left_pyramid, __global const uchar* right_pyramid,
                        const porta_levels* layout, porta_keypoint kl, __global const porta_keypoint* right,
                        ulong best, const porta_level_ints* scales, int min_disparity, int max_disparity,
                        int max_hamming, int* disparity, int* right_index) {
  const int nl = kl.level;
  if (best == ~0ul || nl >= layout->count) return -1;
  const int best_j = (int)(best & 0xFFFFFFFFul);
  const int best_distance = (int)(best >> 32);
  if (best_distance >= max_hamming) return -1;

  // c: SAD search at the left level around the right keypoint's column taken to that level.
  const porta_plane plane = layout->level[nl];
  const porta_keypoint kr = right[best_j];
  long xr = kr.x;
  if (kr.level != nl) {
    // R = round(S[nR] / S[nL]) in Q16, as (S[nR] * 65536 + S[nL] / 2) / S[nL].
    const long s_right = scales->v[kr.level], s_left = scales->v[nl];
    if (s_left == 0) return -1;  // a zero scale is no level (the cpu backend divides by zero)
    const long ratio = (s_right * 65536 + s_left / 2) / s_left;
    xr = ((long)kr.x * ratio + 32768) >> 16;
  }
  const int reach = MATCH_SAD_HALF_WINDOW + MATCH_SAD_SEARCH;
  if (xr - reach < 0 || xr + reach >= plane.width) return -1;
  if (kl.x < MATCH_SAD_HALF_WINDOW || kl.x + MATCH_SAD_HALF_WINDOW >= plane.width ||
      kl.y < MATCH_SAD_HALF_WINDOW || kl.y + MATCH_SAD_HALF_WINDOW >= plane.height)
    return -1;
  __global const uchar* left_level = left_pyramid + plane.offset_bytes;
  __global const uchar* right_level = right_pyramid + plane.offset_bytes;
  int sads[MATCH_SAD_SLOTS];
  int best_slot = 0;
  for (int slot = 0; slot < MATCH_SAD_SLOTS; ++slot) {
    sads[slot] = match_centred_sad(left_level, right_level, plane.pitch, kl.x,
                                   (int)xr + slot - MATCH_SAD_SEARCH, kl.y);
    if (sads[slot] < sads[best_slot]) best_slot = slot;  // strict: ties keep the smaller increment
  }
  if (best_slot == 0 || best_slot == MATCH_SAD_SLOTS - 1) return -1;

  // d: parabola through the best SAD and its neighbours, rounded half away from zero.
  const long d1 = sads[best_slot - 1], d2 = sads[best_slot], d3 = sads[best_slot + 1];
  const long den = 2 * (d1 + d3 - 2 * d2);
  const long diff = d1 - d3;
  if (den <= 0) return -1;
  if ((diff < 0 ? -diff : diff) > den) return -1;
  const long num = diff * 256;
  const long magnitude = ((num < 0 ? -num : num) * 2 + den) / (2 * den);
  const long delta_q8 = num < 0 ? -magnitude : magnitude;

  // e: disparity at the left level, then at level 0 (64-bit, rounded half up).
  const int inc = best_slot - MATCH_SAD_SEARCH;
  const long level_disparity = ((long)kl.x - xr - inc) * 256 - delta_q8;
  if (level_disparity < 0) return -1;
  const int d0 = (int)(((long)(int)level_disparity * scales->v[nl] + 32768) >> 16);
  if (d0 < min_disparity || d0 > max_disparity) return -1;
  *disparity = d0;
  *right_index = best_j;
  return sads[best_slot];
}

// Slot i's result: matches[i] ({-1, -1} for none), sads[i] (-1 for none), and an accepted SAD
// counted in the median histogram (atomic increments: the counts do not depend on the order).
inline void match_store(int i, int sad, int disparity, int right_index, __global int* matches, __global int* sads,
                        __global uint* histogram) {
  if (sad >= 0) {
    atomic_inc(histogram + sad);
    atomic_inc(histogram + MATCH_HIST_COARSE + (sad >> 8));
  }
  matches[2 * i] = sad < 0 ? -1 : disparity;
  matches[2 * i + 1] = sad < 0 ? -1 : right_index;
  sads[i] = sad;
}

inline int match_left_keypoint(__global const uchar* left_pyramid, __global const uchar* right_pyramid,
                               const porta_levels* layout, porta_keypoint kl,
                               __global const uint* left_descriptor, __global const porta_keypoint* right,
                               __global const uint* right_descriptors, int num_right,
                               const porta_level_ints* scales, const porta_level_ints* radius,
                               int min_disparity, int max_disparity, int max_hamming, int* disparity,
                               int* right_index) {
  const ulong best = match_scan_right(layout, kl, left_descriptor, right, right_descriptors, 0, 1, num_right, scales,
                                      radius, min_disparity, max_disparity);
  return match_refine(left_pyramid, right_pyramid, layout, kl, right, best, scales, min_disparity, max_disparity,
                      max_hamming, disparity, right_index);
}

// The arguments of both candidate-search kernels (the host sets them in this order).
#define STEREO_CANDIDATES_PARAMS                                                                      \
  __global const uchar *left_pyramid, __global const uchar *right_pyramid, const porta_levels layout,  \
      __global const porta_keypoint *left, __global const uchar *left_count, const long left_count_offset, \
      const int left_capacity, __global const uint *left_descriptors, __global const porta_keypoint *right, \
      __global const uchar *right_count, const long right_count_offset, const int right_capacity,        \
      __global const uint *right_descriptors, const porta_level_ints scales, const porta_level_ints radius, \
      const int min_disparity, const int max_disparity, const int max_hamming, __global int *matches,    \
      __global int *sads, __global uint *histogram

// DESIGN.md §3.9 step a-e, stereo_match_candidates: one work-item per left list slot; writes matches[i]
// ({-1, -1} for none) and its SAD (-1 for none) into sads[i], and counts each accepted SAD in the
// median histogram (atomic increments: the counts do not depend on the order).
__kernel void stereo_match_candidates(STEREO_CANDIDATES_PARAMS) {
  const int i = (int)get_global_id(0);
  if (i >= match_list_count(left_count, left_count_offset, left_capacity)) return;
  const int num_right = match_list_count(right_count, right_count_offset, right_capacity);
  int disparity = -1, right_index = -1;
  const int sad = match_left_keypoint(
      left_pyramid, right_pyramid, &layout, left[i], left_descriptors + (long)i * 8, right, right_descriptors,
      num_right, &scales, &radius, min_disparity, max_disparity, max_hamming, &disparity, &right_index);
  match_store(i, sad, disparity, right_index, matches, sads, histogram);
}

// The same for GPUs: one 64-wide work-group per left list slot; the work-items scan the right list
// with stride 64 and reduce their (distance << 32) | index minima through local memory, then
// work-item 0 does steps c-e. The same bytes as stereo_match_candidates.
__kernel __attribute__((reqd_work_group_size(64, 1, 1)))
void stereo_match_candidates_group(STEREO_CANDIDATES_PARAMS) {
  __local ulong best[64];
  const int i = (int)get_group_id(0);
  const int lid = (int)get_local_id(0);
  if (i >= match_list_count(left_count, left_count_offset, left_capacity)) return;  // the whole group
  const int num_right = match_list_count(right_count, right_count_offset, right_capacity);
  const porta_keypoint kl = left[i];
  best[lid] = match_scan_right(&layout, kl, left_descriptors + (long)i * 8, right, right_descriptors, lid, 64,
                               num_right, &scales, &radius, min_disparity, max_disparity);
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int stride = 32; stride > 0; stride >>= 1) {
    if (lid < stride && best[lid + stride] < best[lid]) best[lid] = best[lid + stride];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid != 0) return;
  int disparity = -1, right_index = -1;
  const int sad = match_refine(left_pyramid, right_pyramid, &layout, kl, right, best[0], &scales, min_disparity,
                               max_disparity, max_hamming, &disparity, &right_index);
  match_store(i, sad, disparity, right_index, matches, sads, histogram);
}

// DESIGN.md §3.9 step f, stereo_match_median: a single work-item; the median is the accepted SAD at index
// count / 2 in ascending order, found by walking the coarse then the fine histogram; -1 when no
// match was accepted.
__kernel void stereo_match_median(__global uint* histogram) {
  if (get_global_id(0) != 0) return;
  uint total = 0;
  for (int b = 0; b < MATCH_SAD_BLOCKS; ++b) total += histogram[MATCH_HIST_COARSE + b];
  int median = -1;
  if (total > 0) {
    const uint k = total / 2;
    uint below = 0;
    int block = 0;
    while (below + histogram[MATCH_HIST_COARSE + block] <= k) below += histogram[MATCH_HIST_COARSE + block++];
    int value = block * 256;
    while (below + histogram[value] <= k) below += histogram[value++];
    median = value;
  }
  histogram[MATCH_HIST_MEDIAN] = (uint)median;
}

// DESIGN.md §3.9 step f, stereo_match_reject: one work-item per left list slot; drops an accepted
// match whose SAD exceeds 2.1x the median (sad * 10 > 21 * median).
__kernel void stereo_match_reject(__global const uchar* left_count, const long left_count_offset,
                                  const int left_capacity, __global const int* sads,
                                  __global const uint* histogram, __global int* matches) {
  const int i = (int)get_global_id(0);
  if (i >= match_list_count(left_count, left_count_offset, left_capacity)) return;
  const int sad = sads[i];
  const int median = (int)histogram[MATCH_HIST_MEDIAN];
  if (sad < 0 || median < 0) return;
  if ((long)sad * 10 > (long)median * 21) {
    matches[2 * i] = -1;
    matches[2 * i + 1] = -1;
  }
}

// Projection query (keypoint.hpp ProjectionQuery), 16 bytes.
typedef struct {
  int u_q8;
  int v_q8;
  int radius_q8;
  uchar min_level;
  uchar max_level;
  ushort reserved;
} match_query;

// DESIGN.md §3.10 projection_match: one work-item per query; among the keypoints with level in
// [min_level, max_level] (and a scale: level < num_scales) within the inclusive square window of
// radius r around (u, v) at level 0, the smallest Hamming distance (ties to the lower index) and
// the smallest distance among the others; results[q] = {best, best_distance, second, 0}, 256 = none.
// Scales of levels >= 12 (never a pyramid level) come from `more_scales`.
__kernel void projection_match(__global const porta_keypoint* keypoints, __global const uchar* count,
                               const long count_offset, const int capacity,
                               __global const uint* keypoint_descriptors, __global const match_query* queries,
                               __global const uint* query_descriptors, const int num_queries,
                               const porta_level_ints scales, __global const int* more_scales,
                               const int num_scales, __global int* results) {
  const int q = (int)get_global_id(0);
  if (q >= num_queries) return;
  const int n = match_list_count(count, count_offset, capacity);
  const match_query query = queries[q];
  __global const uint* d = query_descriptors + (long)q * 8;
  const long r = query.radius_q8;
  int best_index = -1, best_distance = 256, second_distance = 256;
  for (int k = 0; k < n; ++k) {
    const porta_keypoint kp = keypoints[k];
    if (kp.level >= num_scales || kp.level < query.min_level || kp.level > query.max_level) continue;
    const int s = kp.level < PORTA_MAX_LEVELS ? scales.v[kp.level] : more_scales[kp.level - PORTA_MAX_LEVELS];
    const long dv = (long)match_level0_q8(kp.y, s) - query.v_q8;
    const long du = (long)match_level0_q8(kp.x, s) - query.u_q8;
    if (dv < -r || dv > r || du < -r || du > r) continue;
    const int distance = match_hamming(d, keypoint_descriptors + (long)k * 8);
    if (best_index < 0 || distance < best_distance) {
      // The displaced best (256 when there was none) is now a runner-up.
      second_distance = min(second_distance, best_distance);
      best_distance = distance;
      best_index = k;
    } else {
      second_distance = min(second_distance, distance);
    }
  }
  results[4 * q] = best_index;
  results[4 * q + 1] = best_distance;
  results[4 * q + 2] = second_distance;
  results[4 * q + 3] = 0;
}
