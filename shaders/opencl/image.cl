// Image kernels of the OpenCL backend: rectification, pyramid construction and the descriptor
// blur (DESIGN.md §3.1, §3.2, §3.7). Integer arithmetic only; each work-item writes one output
// pixel, so the bytes are those of the cpu backend (backends/cpu/image_kernels.cpp).

// Finds the level of global row `row` when the rows of all levels are laid end to end; sets
// *y to the row within that level. Returns -1 when `row` is past the last level.
inline int porta_image_locate_row(const porta_levels* layout, int row, int* y) {
  for (int n = 0; n < layout->count; ++n) {
    const int h = layout->level[n].height;
    if (row < h) {
      *y = row;
      return n;
    }
    row -= h;
  }
  return -1;
}

// §3.1 rectify (DESIGN.md §3.1): one work-item per destination pixel (x, y); bilinear sample of
// `src` at the Q5 map position (xq, yq): 5-bit weights, (sum w * p + 512) >> 10, taps outside the
// source read 0. Global size: dst width x dst height.
__kernel void rectify(__global const uchar* src, const porta_plane sp, __global const int* map,
                      __global uchar* dst, const porta_plane dp) {
  const int x = (int)get_global_id(0);
  const int y = (int)get_global_id(1);
  if (x >= dp.width || y >= dp.height) return;
  const long m = ((long)y * dp.width + x) * 2;
  const int xq = map[m];
  const int yq = map[m + 1];
  // Floor division by 32 without relying on >> of negative values: fx = xq & 31 (two's
  // complement), and xq - fx is an exact multiple of 32.
  const uint fx = (uint)(xq & 31);
  const uint fy = (uint)(yq & 31);
  const int x0 = (xq - (int)fx) / 32;
  const int y0 = (yq - (int)fy) / 32;
  __global const uchar* s = src + sp.offset_bytes;
  uint p00 = 0, p10 = 0, p01 = 0, p11 = 0;
  const bool in_x0 = x0 >= 0 && x0 < sp.width;
  const bool in_x1 = x0 + 1 >= 0 && x0 + 1 < sp.width;
  if (y0 >= 0 && y0 < sp.height) {
    __global const uchar* row = s + (long)y0 * sp.pitch;
    if (in_x0) p00 = row[x0];
    if (in_x1) p10 = row[x0 + 1];
  }
  if (y0 + 1 >= 0 && y0 + 1 < sp.height) {
    __global const uchar* row = s + (long)(y0 + 1) * sp.pitch;
    if (in_x0) p01 = row[x0];
    if (in_x1) p11 = row[x0 + 1];
  }
  const uint sum = (32 - fx) * (32 - fy) * p00 + fx * (32 - fy) * p10 + (32 - fx) * fy * p01 + fx * fy * p11;
  dst[dp.offset_bytes + (long)y * dp.pitch + x] = (uchar)((sum + 512) >> 10);
}

// §3.2 pyramid (DESIGN.md §3.2): one level from the level above, one work-item per destination
// pixel; `table` + `table_offset` holds cols.src0, cols.w1 (W), rows.src0, rows.w1 (H) of this
// level (ResizeTables::packed); value (wy0*(wx0*p00 + wx1*p10) + wy1*(wx0*p01 + wx1*p11) + 2^21) >> 22.
// The source pixels and weights of pixel (x, y) of `level` from `above`.
typedef struct {
  int x0, x1, y0, y1;
  uint wx0, wx1, wy0, wy1;
} porta_resize_taps;

porta_resize_taps porta_resize_taps_of(__global const int* table, int table_offset, const porta_plane above,
                                       const porta_plane level, int x, int y) {
  __global const int* col_src0 = table + table_offset;
  __global const int* col_w1 = col_src0 + level.width;
  __global const int* row_src0 = col_w1 + level.width;
  __global const int* row_w1 = row_src0 + level.height;
  porta_resize_taps t;
  t.y0 = row_src0[y];
  t.y1 = min(t.y0 + 1, above.height - 1);
  t.wy1 = (uint)row_w1[y];
  t.wy0 = 2048 - t.wy1;
  t.x0 = col_src0[x];
  t.x1 = min(t.x0 + 1, above.width - 1);
  t.wx1 = (uint)col_w1[x];
  t.wx0 = 2048 - t.wx1;
  return t;
}

// The rounded value from the four source pixels: p00 at (x0, y0), p10 at (x1, y0), p01 at (x0, y1).
uint porta_resize_value(const porta_resize_taps t, uint p00, uint p10, uint p01, uint p11) {
  const uint sum = t.wy0 * (t.wx0 * p00 + t.wx1 * p10) + t.wy1 * (t.wx0 * p01 + t.wx1 * p11);
  return (sum + (1u << 21)) >> 22;
}

__kernel void build_pyramid_level(__global uchar* pyramid, const porta_plane above, const porta_plane level,
                                  __global const int* table, const int table_offset) {
  const int j = (int)get_global_id(0);
  const int i = (int)get_global_id(1);
  if (j >= level.width || i >= level.height) return;
  const porta_resize_taps t = porta_resize_taps_of(table, table_offset, above, level, j, i);
  __global const uchar* top = pyramid + above.offset_bytes + (long)t.y0 * above.pitch;
  __global const uchar* bottom = pyramid + above.offset_bytes + (long)t.y1 * above.pitch;
  pyramid[level.offset_bytes + (long)i * level.pitch + j] =
      (uchar)porta_resize_value(t, top[t.x0], top[t.x1], bottom[t.x0], bottom[t.x1]);
}

// §3.2 pyramid on GPUs, levels 1..m in one launch (as build_pyramid_level; the Vulkan shader
// build_pyramid_fused.comp says how): one 32 x 8 work-group per tile of those levels (`tiles`),
// computing from level 0 the regions of levels 1..n-1 its level-n tile reads into local memory,
// level by level, then the tile. table_offset.v[n]: where level n's tables start.
#define PORTA_REGION_WORDS 2048

// Source pixel (x, y) of level k - 1: level 0 from the pyramid, else from the region at `region`
// whose top-left pixel is (xa, ya) and rows `stride` bytes.
uint porta_pyramid_fetch(__global const uchar* pyramid, const porta_plane zero, __local const uint* region, int k,
                         int stride, int xa, int ya, int x, int y) {
  if (k == 1) return pyramid[zero.offset_bytes + (long)y * zero.pitch + x];
  const int i = clamp((y - ya) * stride + (x - xa), 0, 4 * PORTA_REGION_WORDS - 1);
  return (region[i >> 2] >> (8 * (i & 3))) & 255u;
}

uint porta_pyramid_resample(__global const uchar* pyramid, const porta_plane zero, const porta_plane above,
                            const porta_plane level, __global const int* table, int table_offset,
                            __local const uint* region, int k, int stride, int xa, int ya, int x, int y) {
  const porta_resize_taps t = porta_resize_taps_of(table, table_offset, above, level, x, y);
  return porta_resize_value(t, porta_pyramid_fetch(pyramid, zero, region, k, stride, xa, ya, t.x0, t.y0),
                            porta_pyramid_fetch(pyramid, zero, region, k, stride, xa, ya, t.x1, t.y0),
                            porta_pyramid_fetch(pyramid, zero, region, k, stride, xa, ya, t.x0, t.y1),
                            porta_pyramid_fetch(pyramid, zero, region, k, stride, xa, ya, t.x1, t.y1));
}

__kernel __attribute__((reqd_work_group_size(PORTA_TILE_W, PORTA_TILE_H, 1)))
void build_pyramid_fused(__global uchar* pyramid, const porta_levels layout, __global const int* table,
                         const porta_tiles tiles, const porta_level_ints table_offset) {
  __local uint region[2 * PORTA_REGION_WORDS];
  int n;
  int2 origin;
  PORTA_TILE_OF(tiles, layout.count, (int)get_group_id(0), n, origin);
  if (n < 1) return;  // the whole work-group
  int xa[PORTA_MAX_LEVELS], xb[PORTA_MAX_LEVELS], ya[PORTA_MAX_LEVELS], yb[PORTA_MAX_LEVELS];
  xa[n] = origin.x;
  xb[n] = min(origin.x + PORTA_TILE_W, layout.level[n].width) - 1;
  ya[n] = origin.y;
  yb[n] = min(origin.y + PORTA_TILE_H, layout.level[n].height) - 1;
  for (int k = n; k >= 2; --k) {
    __global const int* cols = table + table_offset.v[k];
    __global const int* rows = cols + 2 * layout.level[k].width;
    xa[k - 1] = cols[xa[k]];
    xb[k - 1] = min(cols[xb[k]] + 1, layout.level[k - 1].width - 1);
    ya[k - 1] = rows[ya[k]];
    yb[k - 1] = min(rows[yb[k]] + 1, layout.level[k - 1].height - 1);
  }
  const porta_plane zero = layout.level[0];
  const int tx = (int)get_local_id(0), ty = (int)get_local_id(1);
  const int tid = ty * PORTA_TILE_W + tx;
  for (int k = 1; k < n; ++k) {  // regions of levels 1..n-1, 4 pixels per step
    __local const uint* src = region + ((k - 1) & 1) * PORTA_REGION_WORDS;
    const int src_stride = k == 1 ? 0 : ((xb[k - 1] - xa[k - 1] + 4) >> 2) * 4;
    __local uint* dst = region + (k & 1) * PORTA_REGION_WORDS;
    const int cols = xb[k] - xa[k] + 1;
    const int words = (cols + 3) >> 2;
    const int steps = words * (yb[k] - ya[k] + 1);
    for (int q = tid; q < steps; q += PORTA_TILE_W * PORTA_TILE_H) {
      const int r = q / words, c = (q - r * words) * 4;
      uint word = 0;
      for (int e = 0; e < 4 && c + e < cols; ++e)
        word |= porta_pyramid_resample(pyramid, zero, layout.level[k - 1], layout.level[k], table, table_offset.v[k],
                                       src, k, src_stride, xa[k - 1], ya[k - 1], xa[k] + c + e, ya[k] + r)
                << (8 * e);
      dst[min(q, PORTA_REGION_WORDS - 1)] = word;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  const porta_plane level = layout.level[n];
  const int x = origin.x + tx, y = origin.y + ty;
  if (x >= level.width || y >= level.height) return;
  const int src_stride = n == 1 ? 0 : ((xb[n - 1] - xa[n - 1] + 4) >> 2) * 4;
  pyramid[level.offset_bytes + (long)y * level.pitch + x] = (uchar)porta_pyramid_resample(
      pyramid, zero, layout.level[n - 1], level, table, table_offset.v[n], region + ((n - 1) & 1) * PORTA_REGION_WORDS,
      n, src_stride, xa[n - 1], ya[n - 1], x, y);
}

// §3.7 blur, horizontal pass (DESIGN.md §3.7), for CPU devices and for a blur in place: all levels
// in one launch, one work-item per row (global: the rows of all levels laid end to end), walking
// the row in a loop, the three columns at each end by reflect101 and the rest without it; h = sum t_k * p(reflect101(x + k - 3)) unrounded, into the uint16 scratch plane
// of the level (packed, pitch = width, at element scratch_offset.v[n]).
__kernel void blur_horizontal(__global const uchar* restrict pyramid, const porta_levels layout,
                              __global ushort* restrict scratch, const porta_level_ints scratch_offset,
                              const porta_level_ints taps) {
  int y = 0;
  const int n = porta_image_locate_row(&layout, (int)get_global_id(0), &y);
  if (n < 0) return;
  const porta_plane p = layout.level[n];
  const int w = p.width;
  __global const uchar* row = pyramid + p.offset_bytes + (long)y * p.pitch;
  __global ushort* out = scratch + scratch_offset.v[n] + (long)y * w;
  const uint t0 = (uint)taps.v[0], t1 = (uint)taps.v[1], t2 = (uint)taps.v[2], t3 = (uint)taps.v[3];
  const uint t4 = (uint)taps.v[4], t5 = (uint)taps.v[5], t6 = (uint)taps.v[6];
  const int head = min(3, w), tail = max(head, w - 3);
  for (int x = 0; x < w; x = x + 1 == head ? tail : x + 1) {  // the ends: x < head and x >= tail
    uint sum = 0;
    for (int k = 0; k < 7; ++k) sum += (uint)taps.v[k] * row[porta_reflect101(x + k - 3, w)];
    out[x] = (ushort)sum;
  }
  for (int x = head; x < tail; ++x) {
    out[x] = (ushort)(t0 * row[x - 3] + t1 * row[x - 2] + t2 * row[x - 1] + t3 * row[x] + t4 * row[x + 1] +
                      t5 * row[x + 2] + t6 * row[x + 3]);
  }
}

// §3.7 blur, vertical pass (DESIGN.md §3.7): out = (sum t_k * h(reflect101(y + k - 3)) + 2^15) >> 16
// into the blurred pyramid (same layout as the source); one work-item per row as blur_horizontal.
__kernel void blur_vertical(__global const ushort* restrict scratch, const porta_levels layout,
                            __global uchar* restrict blurred, const porta_level_ints scratch_offset,
                            const porta_level_ints taps) {
  int y = 0;
  const int n = porta_image_locate_row(&layout, (int)get_global_id(0), &y);
  if (n < 0) return;
  const porta_plane p = layout.level[n];
  const int w = p.width;
  __global const ushort* plane = scratch + scratch_offset.v[n];
  __global const ushort* h0 = plane + (long)porta_reflect101(y - 3, p.height) * w;
  __global const ushort* h1 = plane + (long)porta_reflect101(y - 2, p.height) * w;
  __global const ushort* h2 = plane + (long)porta_reflect101(y - 1, p.height) * w;
  __global const ushort* h3 = plane + (long)y * w;
  __global const ushort* h4 = plane + (long)porta_reflect101(y + 1, p.height) * w;
  __global const ushort* h5 = plane + (long)porta_reflect101(y + 2, p.height) * w;
  __global const ushort* h6 = plane + (long)porta_reflect101(y + 3, p.height) * w;
  __global uchar* out = blurred + p.offset_bytes + (long)y * p.pitch;
  const uint t0 = (uint)taps.v[0], t1 = (uint)taps.v[1], t2 = (uint)taps.v[2], t3 = (uint)taps.v[3];
  const uint t4 = (uint)taps.v[4], t5 = (uint)taps.v[5], t6 = (uint)taps.v[6];
  int x = 0;
  for (; x + 8 <= w; x += 8) {  // eight columns at a time, in vector registers
    const uint8 sum = t0 * convert_uint8(vload8(0, h0 + x)) + t1 * convert_uint8(vload8(0, h1 + x)) +
                      t2 * convert_uint8(vload8(0, h2 + x)) + t3 * convert_uint8(vload8(0, h3 + x)) +
                      t4 * convert_uint8(vload8(0, h4 + x)) + t5 * convert_uint8(vload8(0, h5 + x)) +
                      t6 * convert_uint8(vload8(0, h6 + x));
    vstore8(convert_uchar8((sum + (1u << 15)) >> 16), 0, out + x);
  }
  for (; x < w; ++x) {
    const uint sum = t0 * h0[x] + t1 * h1[x] + t2 * h2[x] + t3 * h3[x] + t4 * h4[x] + t5 * h5[x] + t6 * h6[x];
    out[x] = (uchar)((sum + (1u << 15)) >> 16);
  }
}

// §3.7 blur on GPUs (as blur_horizontal + blur_vertical): one 32 x 8 work-group per tile of any
// level (`tiles`), both passes through local memory. Row r of the tile's source holds source row
// reflect101(y0 - 3 + r), column c source column reflect101(x0 - 3 + c); the horizontal sums h =
// sum t_k p stay unrounded (the cpu's uint16) for the 14 rows the tile needs, then out = (sum t_k h
// + 2^15) >> 16. Source and destination must differ (the host launches the two passes otherwise).
__kernel __attribute__((reqd_work_group_size(PORTA_TILE_W, PORTA_TILE_H, 1)))
void blur_tiled(__global const uchar* pyramid, const porta_levels layout, __global uchar* blurred,
                const porta_tiles tiles, const porta_level_ints taps) {
  __local uint source[PORTA_TILE_H + 6][PORTA_TILE_W + 6];
  __local uint horizontal[PORTA_TILE_H + 6][PORTA_TILE_W];
  int n;
  int2 origin;
  PORTA_TILE_OF(tiles, layout.count, (int)get_group_id(0), n, origin);
  if (n < 0) return;  // the whole work-group
  const porta_plane p = layout.level[n];
  const int tx = (int)get_local_id(0), ty = (int)get_local_id(1);
  const int tid = ty * PORTA_TILE_W + tx;
  for (int k = tid; k < (PORTA_TILE_H + 6) * (PORTA_TILE_W + 6); k += PORTA_TILE_W * PORTA_TILE_H) {
    const int r = k / (PORTA_TILE_W + 6), c = k - r * (PORTA_TILE_W + 6);
    const int sy = porta_reflect101(origin.y - 3 + r, p.height);
    const int sx = porta_reflect101(origin.x - 3 + c, p.width);
    source[r][c] = pyramid[p.offset_bytes + (long)sy * p.pitch + sx];
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int k = tid; k < (PORTA_TILE_H + 6) * PORTA_TILE_W; k += PORTA_TILE_W * PORTA_TILE_H) {
    const int r = k / PORTA_TILE_W, c = k - r * PORTA_TILE_W;
    uint sum = 0;
    for (int t = 0; t < 7; ++t) sum += (uint)taps.v[t] * source[r][c + t];
    horizontal[r][c] = sum;
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  const int x = origin.x + tx, y = origin.y + ty;
  if (x >= p.width || y >= p.height) return;
  uint sum = 0;  // at most 256 * 65280 + 2^15 < 2^24
  for (int t = 0; t < 7; ++t) sum += (uint)taps.v[t] * horizontal[ty + t][tx];
  blurred[p.offset_bytes + (long)y * p.pitch + x] = (uchar)((sum + (1u << 15)) >> 16);
}
