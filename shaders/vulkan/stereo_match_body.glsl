// The body of stereo_match_candidates.comp (one workgroup of 64 per left list slot) and of
// stereo_match_candidates_per_item.comp (STEREO_PER_ITEM: one invocation per slot, for CPU devices
// such as lavapipe, where the workgroup's barriers cost more than they save): the same steps and
// the same bytes, the per-item shader scanning the right list alone, computing the 11 SADs in a
// loop and finishing itself. The including shader declares the local size.

layout(std430, set = 0, binding = 0) readonly buffer LeftPyramid { uint8_t left_pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer RightPyramid { uint8_t right_pyramid[]; };
layout(std430, set = 0, binding = 2) readonly buffer LeftKeypoints { uvec2 left_kp[]; };
layout(std430, set = 0, binding = 3) readonly buffer LeftCount { uint8_t left_count[]; };
layout(std430, set = 0, binding = 4) readonly buffer LeftDescriptors { uint left_desc[]; };
layout(std430, set = 0, binding = 5) readonly buffer RightKeypoints { uvec2 right_kp[]; };
layout(std430, set = 0, binding = 6) readonly buffer RightCount { uint8_t right_count[]; };
layout(std430, set = 0, binding = 7) readonly buffer RightDescriptors { uint right_desc[]; };
layout(std430, set = 0, binding = 8) writeonly buffer Matches { ivec2 matches[]; };
layout(std430, set = 0, binding = 9) writeonly buffer Sads { int sads[]; };
layout(std430, set = 0, binding = 10) buffer Histogram { uint histogram[]; };
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  int scales[PORTA_MAX_LEVELS];      // S[n], Q16
  int row_radius[PORTA_MAX_LEVELS];  // per right-keypoint level, 1/256 px
  int left_capacity;
  uint left_count_offset;
  int right_capacity;
  uint right_count_offset;
  int min_disparity;  // 1/256 px
  int max_disparity;
  int max_hamming;  // the best distance must be strictly below
} p;

#ifdef STEREO_PER_ITEM
#define GROUP 1u
#else
#define GROUP 64u
#endif
#define SAD_HALF_WINDOW 5
#define SAD_SEARCH 5
#define SAD_SLOTS (2 * SAD_SEARCH + 1)
#define NO_CANDIDATE 0xFFFFFFFFFFFFFFFFul

#ifndef STEREO_PER_ITEM
shared uint64_t best_key[GROUP];
shared int slot_sad[SAD_SLOTS];
#endif

// Sum over the 11 x 11 window of |(L(p) - L(centre)) - (R(p + shift) - R(centre + shift))|.
int centred_sad(int level_offset, int pitch, int x_left, int x_right, int y) {
  const int lc = int(uint(left_pyramid[level_offset + y * pitch + x_left]));
  const int rc = int(uint(right_pyramid[level_offset + y * pitch + x_right]));
  int sad = 0;
  for (int dy = -SAD_HALF_WINDOW; dy <= SAD_HALF_WINDOW; ++dy) {
    const int row = level_offset + (y + dy) * pitch;
    for (int dx = -SAD_HALF_WINDOW; dx <= SAD_HALF_WINDOW; ++dx) {
      const int diff = (int(uint(left_pyramid[row + x_left + dx])) - lc) -
                       (int(uint(right_pyramid[row + x_right + dx])) - rc);
      sad += abs(diff);
    }
  }
  return sad;
}

void main() {
#ifdef STEREO_PER_ITEM
  const uint i = porta_linear_index();  // one invocation per slot: it alone takes every step
  const uint lid = 0u;
#else
  const uint i = porta_linear_group();  // uniform over the workgroup: so are all early returns
  const uint lid = gl_LocalInvocationID.x;
#endif
  if (i >= uint(PORTA_LIST_LENGTH(left_count, p.left_count_offset, p.left_capacity))) return;
  const uvec2 kl = left_kp[i];
  const int levels = p.layout_.count;
  const int nl = int(kp_level(kl));
  if (nl >= levels) {
    if (lid == 0u) {
      matches[i] = ivec2(-1);
      sads[i] = -1;
    }
    return;
  }
  const int ul = porta_level0_q8(kp_x(kl), p.scales[nl]);
  const int vl = porta_level0_q8(kp_y(kl), p.scales[nl]);

  // a, b: candidates are right keypoints of levels nl-1..nl+1 whose level-0 row is within the
  // row radius of their level and whose disparity lies in [min, max] (64-bit, as the cpu).
  uint dl[8];
  for (uint w = 0u; w < 8u; ++w) dl[w] = left_desc[i * 8u + w];
  const int num_right = PORTA_LIST_LENGTH(right_count, p.right_count_offset, p.right_capacity);
  const int lo_level = max(0, nl - 1), hi_level = min(levels - 1, nl + 1);
  uint64_t key = NO_CANDIDATE;
  for (uint j = lid; j < uint(num_right); j += GROUP) {
    const uvec2 kr = right_kp[j];
    const int nr = int(kp_level(kr));
    if (nr < lo_level || nr > hi_level) continue;
    const int s = p.scales[nr];
    const int64_t r = int64_t(p.row_radius[nr]);
    const int64_t vr = int64_t(porta_level0_q8(kp_y(kr), s));
    if (vr < int64_t(vl) - r || vr > int64_t(vl) + r) continue;
    const int64_t d = int64_t(ul) - int64_t(porta_level0_q8(kp_x(kr), s));
    if (d < int64_t(p.min_disparity) || d > int64_t(p.max_disparity)) continue;
    uint distance = 0u;
    for (uint w = 0u; w < 8u; ++w) distance += uint(bitCount(dl[w] ^ right_desc[j * 8u + w]));
    const uint64_t k = (uint64_t(distance) << 32) | uint64_t(j);
    key = min(key, k);
  }
#ifdef STEREO_PER_ITEM
  const uint64_t best = key;
#else
  best_key[lid] = key;
  barrier();
  for (uint stride = GROUP / 2u; stride > 0u; stride >>= 1) {
    if (lid < stride) best_key[lid] = min(best_key[lid], best_key[lid + stride]);
    barrier();
  }
  const uint64_t best = best_key[0];
#endif

  // The checks below depend only on values every invocation shares: the whole workgroup leaves.
  bool ok = best != NO_CANDIDATE && int(best >> 32) < p.max_hamming;
  const int best_j = int(uint(best & 0xFFFFFFFFul));
  const Plane plane = p.layout_.level[nl];
  int64_t xr = 0;
  if (ok) {
    // c: the right keypoint's column taken to the left level.
    const uvec2 kr = right_kp[best_j];
    const int nr = int(kp_level(kr));
    xr = int64_t(kp_x(kr));
    if (nr != nl) {
      // R = (S[nR] * 65536 + S[nL] / 2) / S[nL] (level_ratio_q16), xR = (x * R + 2^15) >> 16.
      const int s_left = p.scales[nl];
      if (s_left == 0) {
        ok = false;  // a zero scale is no level (the cpu backend would divide by zero)
      } else {
        const int64_t ratio = (int64_t(p.scales[nr]) * 65536l + int64_t(s_left / 2)) / int64_t(s_left);
        xr = (int64_t(kp_x(kr)) * ratio + 32768l) >> 16;
      }
    }
    const int reach = SAD_HALF_WINDOW + SAD_SEARCH;
    if (xr - reach < 0l || xr + reach >= int64_t(plane.width)) ok = false;
    const int x = int(kp_x(kl)), y = int(kp_y(kl));
    if (x < SAD_HALF_WINDOW || x + SAD_HALF_WINDOW >= plane.width || y < SAD_HALF_WINDOW ||
        y + SAD_HALF_WINDOW >= plane.height)
      ok = false;
  }
  if (!ok) {
    if (lid == 0u) {
      matches[i] = ivec2(-1);
      sads[i] = -1;
    }
    return;
  }

#ifdef STEREO_PER_ITEM
  int slot_sad[SAD_SLOTS];
  for (int slot = 0; slot < SAD_SLOTS; ++slot)
    slot_sad[slot] = centred_sad(plane.offset_bytes, plane.pitch, int(kp_x(kl)), int(xr) + slot - SAD_SEARCH,
                                 int(kp_y(kl)));
#else
  if (lid < uint(SAD_SLOTS))
    slot_sad[lid] = centred_sad(plane.offset_bytes, plane.pitch, int(kp_x(kl)),
                                int(xr) + int(lid) - SAD_SEARCH, int(kp_y(kl)));
  barrier();
  if (lid != 0u) return;
#endif

  int best_slot = 0;
  for (int slot = 1; slot < SAD_SLOTS; ++slot)
    if (slot_sad[slot] < slot_sad[best_slot]) best_slot = slot;  // strict: ties keep the smaller inc
  int disparity = -1, right_index = -1, sad = -1;
  if (best_slot != 0 && best_slot != SAD_SLOTS - 1) {
    // d: parabola through the best SAD and its neighbours, rounded half away from zero.
    const int64_t d1 = int64_t(slot_sad[best_slot - 1]), d2 = int64_t(slot_sad[best_slot]),
                  d3 = int64_t(slot_sad[best_slot + 1]);
    const int64_t den = 2l * (d1 + d3 - 2l * d2);
    const int64_t diff = d1 - d3;
    if (den > 0l && abs(diff) <= den) {
      const int64_t num = diff * 256l;
      const int64_t magnitude = (abs(num) * 2l + den) / (2l * den);
      const int64_t delta_q8 = num < 0l ? -magnitude : magnitude;
      // e: disparity at the left level, then at level 0 (64-bit, rounded half up).
      const int inc = best_slot - SAD_SEARCH;
      const int64_t level_disparity = (int64_t(kp_x(kl)) - xr - int64_t(inc)) * 256l - delta_q8;
      if (level_disparity >= 0l) {
        const int d0 = int((int64_t(int(level_disparity)) * int64_t(p.scales[nl]) + 32768l) >> 16);
        if (d0 >= p.min_disparity && d0 <= p.max_disparity) {
          disparity = d0;
          right_index = best_j;
          sad = slot_sad[best_slot];
        }
      }
    }
  }
  matches[i] = ivec2(disparity, right_index);
  sads[i] = sad;
  if (sad >= 0) {
    atomicAdd(histogram[sad], 1u);
    atomicAdd(histogram[STEREO_HIST_COARSE + (sad >> 8)], 1u);
  }
}
