// Orientation and ORB descriptor kernels (DESIGN.md §3.6, §3.8; docs/ARCHITECTURE.md). The cpu
// backend (backends/cpu/describe_kernels.cpp) defines the result. Both launch over a keypoint
// list's capacity and read the list's length on the device.

#define DESCRIBE_ORIENT_RADIUS 15
#define DESCRIBE_ORB_REACH 18

// The 16 half-widths umax[dy] of the orientation disc, passed by value.
typedef struct {
  int v[DESCRIBE_ORIENT_RADIUS + 1];
} describe_umax;

// The length of a device list: the uint32 at count + offset (read bytewise, so any offset works),
// at most `capacity`.
inline int describe_list_count(__global const uchar* count, long offset, int capacity) {
  if (capacity <= 0) return 0;  // an empty list need not have a count to read
  __global const uchar* p = count + offset;
  const uint n = (uint)p[0] | ((uint)p[1] << 8) | ((uint)p[2] << 16) | ((uint)p[3] << 24);
  return n < (uint)capacity ? (int)n : capacity;
}

// A keypoint whose level exists and which lies at least `reach` px inside its level. The cpu
// backend rejects any other keypoint with an error before it starts; here it is left alone.
inline bool describe_keypoint_ok(porta_keypoint kp, const porta_levels* layout, int reach) {
  if (kp.level >= layout->count) return false;
  const porta_plane plane = layout->level[kp.level];
  return kp.x >= reach && kp.y >= reach && kp.x + reach < plane.width && kp.y + reach < plane.height;
}

// DESIGN.md §3.6 orient: one work-item per list slot; sets angle_bin of keypoint i from the moments
// m10 = sum dx*I, m01 = sum dy*I over the disc |dy| <= 15, |dx| <= umax[|dy|] of its unblurred
// level: the first bin b with cross(u_b, m) >= 0 > cross(u_{b+1 mod B}, m), bin 0 when none.
// The first bin b with cross(u_b, m) >= 0 > cross(u_{b+1 mod B}, m) for the moments (m10, m01);
// bin 0 when none (cross(u, m) = u.x * m01 - u.y * m10, |u| <= 1024: int32).
inline int describe_angle_bin(int m10, int m01, __global const int* boundaries, int bins) {
  for (int b = 0; b < bins; ++b) {
    const int next = b + 1 == bins ? 0 : b + 1;
    const int cross_b = boundaries[2 * b] * m01 - boundaries[2 * b + 1] * m10;
    const int cross_next = boundaries[2 * next] * m01 - boundaries[2 * next + 1] * m10;
    if (cross_b >= 0 && cross_next < 0) return b;
  }
  return 0;
}

// Row dy of the disc around `centre`: adds dx * I to *m10 and dy * sum(I) to *m01.
inline void describe_disc_row(__global const uchar* centre, int pitch, int dy, const describe_umax* umax, int* m10,
                              int* m01) {
  __global const uchar* row = centre + (long)dy * pitch;
  const int half_width = umax->v[dy < 0 ? -dy : dy];
  int row_sum = 0;
  for (int dx = -half_width; dx <= half_width; ++dx) {
    const int p = row[dx];
    row_sum += p;
    *m10 += dx * p;
  }
  *m01 += dy * row_sum;
}

__kernel void orient(__global const uchar* pyramid, const porta_levels layout,
                     __global porta_keypoint* keypoints, __global const uchar* count, const long count_offset,
                     const int capacity, const describe_umax umax, __global const int* boundaries,
                     const int bins) {
  const int i = (int)get_global_id(0);
  if (i >= describe_list_count(count, count_offset, capacity)) return;
  const porta_keypoint kp = keypoints[i];
  if (!describe_keypoint_ok(kp, &layout, DESCRIBE_ORIENT_RADIUS)) return;
  const porta_plane plane = layout.level[kp.level];
  __global const uchar* centre = pyramid + plane.offset_bytes + (long)kp.y * plane.pitch + kp.x;
  // |m| < 2^20 (255 * sum of |dx| over the half disc), so int holds both moments.
  int m10 = 0, m01 = 0;
  for (int dy = -DESCRIBE_ORIENT_RADIUS; dy <= DESCRIBE_ORIENT_RADIUS; ++dy)
    describe_disc_row(centre, plane.pitch, dy, &umax, &m10, &m01);
  keypoints[i].angle_bin = (uchar)describe_angle_bin(m10, m01, boundaries, bins);
}

// The same for GPUs (OpenClBackend::work_groups()): a 32-wide work-group per list slot, work-item
// r < 31 summing row r - 15 of the disc, the integer moments reduced in local memory (the same bytes:
// integer sums do not depend on the order).
__kernel __attribute__((reqd_work_group_size(32, 1, 1)))
void orient_group(__global const uchar* pyramid, const porta_levels layout, __global porta_keypoint* keypoints,
                  __global const uchar* count, const long count_offset, const int capacity,
                  const describe_umax umax, __global const int* boundaries, const int bins) {
  __local int m10_of[32], m01_of[32];
  const int i = (int)get_group_id(0);
  const int lid = (int)get_local_id(0);
  if (i >= describe_list_count(count, count_offset, capacity)) return;  // the whole group
  const porta_keypoint kp = keypoints[i];
  if (!describe_keypoint_ok(kp, &layout, DESCRIBE_ORIENT_RADIUS)) return;
  const porta_plane plane = layout.level[kp.level];
  __global const uchar* centre = pyramid + plane.offset_bytes + (long)kp.y * plane.pitch + kp.x;
  int m10 = 0, m01 = 0;
  if (lid <= 2 * DESCRIBE_ORIENT_RADIUS) describe_disc_row(centre, plane.pitch, lid - DESCRIBE_ORIENT_RADIUS, &umax, &m10, &m01);
  m10_of[lid] = m10;
  m01_of[lid] = m01;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int stride = 16; stride > 0; stride >>= 1) {
    if (lid < stride) {
      m10_of[lid] += m10_of[lid + stride];
      m01_of[lid] += m01_of[lid + stride];
    }
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid == 0) keypoints[i].angle_bin = (uchar)describe_angle_bin(m10_of[0], m01_of[0], boundaries, bins);
}

// DESIGN.md §3.8 orb_describe: one work-item per (list slot, descriptor byte); byte k of descriptor i holds
// bits j = 8k..8k+7 (bit j % 8), bit j = I(p + a_j) < I(p + b_j) on the blurred level with the
// pairs of the keypoint's angle bin (pattern: bins * 256 * (ax, ay, bx, by) int8).
__kernel void orb_describe(__global const uchar* blurred, const porta_levels layout,
                           __global const porta_keypoint* keypoints, __global const uchar* count,
                           const long count_offset, const int capacity, __global const char* pattern,
                           const int bins, __global uchar* descriptors) {
  const int gid = (int)get_global_id(0);
  const int i = gid >> 5;
  const int byte_index = gid & 31;
  if (i >= describe_list_count(count, count_offset, capacity)) return;
  const porta_keypoint kp = keypoints[i];
  if (!describe_keypoint_ok(kp, &layout, DESCRIBE_ORB_REACH) || kp.angle_bin >= bins) return;
  const porta_plane plane = layout.level[kp.level];
  __global const uchar* centre = blurred + plane.offset_bytes + (long)kp.y * plane.pitch + kp.x;
  __global const char* pairs = pattern + ((long)kp.angle_bin * 256 + byte_index * 8) * 4;
  uint bits = 0;
  for (int bit = 0; bit < 8; ++bit) {
    __global const char* p = pairs + bit * 4;
    const uchar a = centre[(long)p[1] * plane.pitch + p[0]];
    const uchar b = centre[(long)p[3] * plane.pitch + p[2]];
    bits |= (uint)(a < b) << bit;
  }
  descriptors[(long)i * 32 + byte_index] = (uchar)bits;
}
