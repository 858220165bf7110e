// Detection kernels of the OpenCL backend: FAST corner response, per-cell culling, pyramidal
// feature aggregation (PFA) and the canonical compaction of the cell array (DESIGN.md §3.3-3.5).
// They reproduce the bytes of the cpu backend (backends/cpu/detect_kernels.cpp).

// The radius-3 Bresenham circle (tables.hpp kFastCircle), in circular order.
__constant int porta_fast_dx[16] = {0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3, -3, -3, -2, -1};
__constant int porta_fast_dy[16] = {-3, -3, -2, -1, 0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3};

// The level of global row `row` when the rows of all levels are laid end to end; *y is the row
// within it. -1 past the last level.
inline int porta_detect_locate_row(const porta_levels* layout, int row, int* y) {
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

// The level whose cells hold frame-wide cell index `cell`; -1 when none does.
inline int porta_locate_cell(const porta_cells* cells, int cell) {
  for (int n = 0; n < cells->count; ++n) {
    const porta_level_cells c = cells->level[n];
    if (cell >= c.first_cell && cell - c.first_cell < c.cols * c.rows) return n;
  }
  return -1;
}

// The FAST response of the pixel at `centre` (at least 3 pixels inside its level): the sum of
// |I_i - c| over the circle when lut[bright] | lut[dark], else 0.
inline ushort porta_fast_response(__global const uchar* centre, const int pitch, __global const uchar* lut,
                                  const int eps) {
  const int c = centre[0];
  uint bright = 0, dark = 0;
  int sum = 0;
  for (int i = 0; i < 16; ++i) {
    const int p = centre[porta_fast_dy[i] * pitch + porta_fast_dx[i]];
    if (p > c + eps) bright |= 1u << i;
    if (p < c - eps) dark |= 1u << i;
    sum += abs(p - c);
  }
  return (lut[bright] | lut[dark]) ? (ushort)sum : (ushort)0;
}

// §3.3 FAST CRF with bounded rectification (DESIGN.md §3.3), for CPU devices: one work-item per
// row of every level (global: the sum of the heights), walking the row sixteen pixels at a time in
// vector types (the circle's 16 offsets fixed for the row). Response = sum |I_i - c| over the circle
// when lut[bright] | lut[dark], else 0; pixels within `edge` of the border get 0, so every pixel of
// the level's width x height is written.
__kernel void fast_crf(__global const uchar* restrict pyramid, const porta_levels layout,
                       __global const uchar* restrict lut, __global ushort* restrict responses,
                       const porta_levels response_layout, const int eps, const int edge) {
  int y = 0;
  const int n = porta_detect_locate_row(&layout, (int)get_global_id(0), &y);
  if (n < 0) return;
  const porta_plane src = layout.level[n];
  const porta_plane dst = response_layout.level[n];
  // Response planes hold 2-byte elements: offset_bytes is even for any layout the engine makes.
  __global ushort* out = (__global ushort*)((__global uchar*)responses + dst.offset_bytes) + (long)y * dst.pitch;
  const bool row_inside = y >= edge && y < src.height - edge;
  const int x_begin = row_inside ? min(max(edge, 0), dst.width) : dst.width;
  const int x_end = row_inside ? max(x_begin, min(src.width - edge, dst.width)) : dst.width;
  for (int x = 0; x < x_begin; ++x) out[x] = 0;
  for (int x = x_end; x < dst.width; ++x) out[x] = 0;
  __global const uchar* row = pyramid + src.offset_bytes + (long)y * src.pitch;
  int offset[16];
  for (int i = 0; i < 16; ++i) offset[i] = porta_fast_dy[i] * src.pitch + porta_fast_dx[i];
  int x = x_begin;
  for (; x + 16 <= x_end; x += 16) {  // sixteen pixels at a time: the tests in vector registers
    const int16 c = convert_int16(vload16(0, row + x));
    const int16 above = c + eps, below = c - eps;
    uint16 bright = (uint16)(0), dark = (uint16)(0);
    int16 sum = (int16)(0);
    for (int i = 0; i < 16; ++i) {
      const int16 q = convert_int16(vload16(0, row + x + offset[i]));
      bright |= as_uint16(q > above) & (uint16)(1u << i);
      dark |= as_uint16(q < below) & (uint16)(1u << i);
      sum += convert_int16(abs_diff(q, c));
    }
    uint b[16], d[16];
    int r[16];
    vstore16(bright, 0, b);
    vstore16(dark, 0, d);
    vstore16(sum, 0, r);
    for (int j = 0; j < 16; ++j) out[x + j] = (lut[b[j]] | lut[d[j]]) ? (ushort)r[j] : (ushort)0;
  }
  for (; x < x_end; ++x) out[x] = porta_fast_response(row + x, src.pitch, lut, eps);
}

// §3.4 feature culling (DESIGN.md §3.4): one work-item per cell of every level (global: cells of
// all levels). The maximum response of the cell, scanned row-major with a strict '>' (ties to the
// smaller row, then column), as a Keypoint; an all-zero record when the maximum is 0.
// A culling cell: its level, its pixels [x0, x1) x [y0, y1) and its level's response rows.
typedef struct {
  int level, x0, y0, x1, y1, pitch;
  __global const ushort* responses;
} porta_cell_area;

// Cell `cell` of the cells of every level; area.level < 0 when no level has it.
inline porta_cell_area porta_locate_cell_area(__global const ushort* responses, const porta_levels* layout,
                                              const porta_cells* cells, int cell) {
  porta_cell_area a;
  a.level = porta_locate_cell(cells, cell);
  if (a.level < 0) return a;
  const porta_level_cells grid = cells->level[a.level];
  const porta_plane plane = layout->level[a.level];
  const int index = cell - grid.first_cell;
  const int cell_y = index / grid.cols;
  const int cell_x = index - cell_y * grid.cols;
  a.y0 = cell_y * grid.cell_h;
  a.y1 = min(a.y0 + grid.cell_h, plane.height);
  a.x0 = cell_x * grid.cell_w;
  a.x1 = min(a.x0 + grid.cell_w, plane.width);
  a.pitch = plane.pitch;
  a.responses = (__global const ushort*)((__global const uchar*)responses + plane.offset_bytes);
  return a;
}

// The cell's record: the maximum response `best` at (x, y) of level n; all zero when best is 0.
inline porta_keypoint porta_cell_keypoint(ushort best, int x, int y, int n) {
  porta_keypoint kp;
  kp.x = best > 0 ? (ushort)x : (ushort)0;
  kp.y = best > 0 ? (ushort)y : (ushort)0;
  kp.response = best;
  kp.level = best > 0 ? (uchar)n : (uchar)0;
  kp.angle_bin = 0;
  return kp;
}

__kernel void cull_cells(__global const ushort* responses, const porta_levels response_layout,
                         const porta_cells cells, __global porta_keypoint* out) {
  const int cell = (int)get_global_id(0);
  const porta_cell_area a = porta_locate_cell_area(responses, &response_layout, &cells, cell);
  if (a.level < 0) return;
  const int n = a.level, x0 = a.x0, x1 = a.x1, y0 = a.y0, y1 = a.y1;
  __global const ushort* level = a.responses;
  const int pitch = a.pitch;
  // The maximum first (a reduction without branches), then its first pixel in row-major order:
  // the pixel a row-major scan keeping a strictly larger response finds.
  ushort best = 0;
  for (int y = y0; y < y1; ++y) {
    __global const ushort* row = level + (long)y * pitch;
    for (int x = x0; x < x1; ++x) best = max(best, row[x]);
  }
  int best_x = 0, best_y = 0;
  bool found = best == 0;
  for (int y = y0; y < y1 && !found; ++y) {
    __global const ushort* row = level + (long)y * pitch;
    for (int x = x0; x < x1; ++x) {
      if (row[x] == best) {
        best_x = x;
        best_y = y;
        found = true;
        break;
      }
    }
  }
  out[cell] = porta_cell_keypoint(best, best_x, best_y, n);
}

// The end of culling by a 64-wide work-group: each work-item's `key` (response << 32) |
// ~(row-major index in the cell) reduced to the maximum through `best` (64 entries of local
// memory), and that maximum written as the record of the cell at (x0, y0), `w` pixels wide, of
// level n (all zero when its response is 0). Every work-item of the group calls it.
inline void porta_write_cell_maximum(__local ulong* best, const int lid, const ulong key, const int x0,
                                     const int y0, const int w, const int n, __global porta_keypoint* out) {
  best[lid] = key;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int stride = 32; stride > 0; stride >>= 1) {
    if (lid < stride && best[lid + stride] > best[lid]) best[lid] = best[lid + stride];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid != 0) return;
  const ulong k = best[0];
  const ushort r = (ushort)(k >> 32);
  const int i = (int)(0xFFFFFFFFu - (uint)(k & 0xFFFFFFFFul));
  *out = r > 0 ? porta_cell_keypoint(r, x0 + i % w, y0 + i / w, n) : porta_cell_keypoint(0, 0, 0, 0);
}

// §3.4 for cells of more than 256 pixels (the backend picks): one 64-wide work-group per cell
// instead of one work-item. Each work-item scans a strided share of the cell, then the group
// reduces through local memory. The key (response << 32) | ~(row-major index in the cell) makes
// the maximum the largest response with ties to the smaller row, then column, as cull_cells'
// scan, whatever the order of the comparisons: the same bytes.
__kernel __attribute__((reqd_work_group_size(64, 1, 1)))
void cull_cells_group(__global const ushort* responses, const porta_levels response_layout,
                      const porta_cells cells, __global porta_keypoint* out) {
  __local ulong best[64];
  const int cell = (int)get_group_id(0);
  const int lid = (int)get_local_id(0);
  const porta_cell_area a = porta_locate_cell_area(responses, &response_layout, &cells, cell);
  if (a.level < 0) return;  // the whole group: `cell` is uniform
  const int w = a.x1 - a.x0, h = a.y1 - a.y0;
  ulong key = 0;
  for (int i = lid; i < w * h; i += 64) {
    const int dy = i / w;
    const int dx = i - dy * w;
    const ulong r = (ulong)a.responses[(long)(a.y0 + dy) * a.pitch + a.x0 + dx];
    const ulong k = (r << 32) | (ulong)(0xFFFFFFFFu - (uint)i);
    key = k > key ? k : key;
  }
  porta_write_cell_maximum(best, lid, key, a.x0, a.y0, w, a.level, out + cell);
}

// PFA helper: the level-0 location index L = Y * width0 + X of a keypoint, X = (x * S[level]) >> 16
// and Y likewise, clamped to the level-0 image (64-bit products, as the cpu backend).
inline uint porta_pfa_location(const porta_keypoint kp, const porta_level_ints scales, const int width0,
                               const int height0) {
  const ulong scale = (ulong)(long)scales.v[kp.level];
  const ulong x = min(((ulong)kp.x * scale) >> 16, (ulong)(width0 - 1));
  const ulong y = min(((ulong)kp.y * scale) >> 16, (ulong)(height0 - 1));
  return (uint)(y * (ulong)width0 + x);
}

// §3.5 PFA (DESIGN.md §3.5), per cell i: each keypoint (response > 0, level < num_scales) of
// the cells projects to a level-0 location L. Both maps are level-0 sized scratch planes that are
// all zero before the first step (the last step restores that). The parameters of every step.
typedef struct {
  porta_level_ints scales;
  int total_cells;
  int num_scales;
  int width0;
  int height0;
  int reach;
} porta_pfa;

inline bool porta_pfa_keypoint(const porta_keypoint kp, const porta_pfa* p) {
  return kp.response != 0 && kp.level < p->num_scales;
}

// Step A: the keypoint adds its response to sum_map[L] and its level bit to level_map[L]. The
// atomics commute, so the result does not depend on their order.
inline void porta_pfa_accumulate_cell(__global const porta_keypoint* cells, int i, const porta_pfa* p,
                                      __global uint* sum_map, __global uint* level_map) {
  const porta_keypoint kp = cells[i];
  if (!porta_pfa_keypoint(kp, p)) return;
  const uint l = porta_pfa_location(kp, p->scales, p->width0, p->height0);
  atomic_add(&sum_map[l], (uint)kp.response);
  atomic_or(&level_map[l], 1u << kp.level);
}

// Step B: score(L) = sum_map[L] * popcount(level_map[L]) (uint32, as the cpu backend).
// rejected[i] = 1 when a location within `reach` of the keypoint's L (clipped to the level-0 image)
// scores strictly more, else 0. Cells and maps are only read.
inline void porta_pfa_decide_cell(__global const porta_keypoint* cells, int i, const porta_pfa* p,
                                  __global const uint* sum_map, __global const uint* level_map,
                                  __global uchar* rejected) {
  const porta_keypoint kp = cells[i];
  uchar reject = 0;
  if (porta_pfa_keypoint(kp, p)) {
    const int width0 = p->width0, height0 = p->height0, reach = p->reach;
    const uint l = porta_pfa_location(kp, p->scales, width0, height0);
    const uint own = sum_map[l] * popcount(level_map[l]);
    const int x = (int)(l % (uint)width0);
    const int y = (int)(l / (uint)width0);
    const int xa = max(0, x - reach), xb = min(width0 - 1, x + reach);
    const int ya = max(0, y - reach), yb = min(height0 - 1, y + reach);
    // Every location of the window is read, with no early exit: the loads go out together.
    for (int wy = ya; wy <= yb; ++wy) {
      const uint row = (uint)wy * (uint)width0;
      for (int wx = xa; wx <= xb; ++wx) {
        const uint k = row + (uint)wx;
        reject |= sum_map[k] * popcount(level_map[k]) > own ? 1 : 0;
      }
    }
  }
  rejected[i] = reject;
}

// Step C: clears the cell if step B rejected it and resets the map entries its keypoint touched to
// 0 (several work-items may write the same 0: benign).
inline void porta_pfa_apply_cell(__global porta_keypoint* cells, int i, const porta_pfa* p,
                                 __global uint* sum_map, __global uint* level_map,
                                 __global const uchar* rejected) {
  const porta_keypoint kp = cells[i];
  if (!porta_pfa_keypoint(kp, p)) return;
  const uint l = porta_pfa_location(kp, p->scales, p->width0, p->height0);
  sum_map[l] = 0;
  level_map[l] = 0;
  if (rejected[i]) cells[i] = porta_cell_keypoint(0, 0, 0, 0);
}

// The three steps, one work-item per cell each.
__kernel void pfa_accumulate(__global const porta_keypoint* cells, const porta_pfa p, __global uint* sum_map,
                             __global uint* level_map) {
  const int i = (int)get_global_id(0);
  if (i < p.total_cells) porta_pfa_accumulate_cell(cells, i, &p, sum_map, level_map);
}

__kernel void pfa_decide(__global const porta_keypoint* cells, const porta_pfa p, __global const uint* sum_map,
                         __global const uint* level_map, __global uchar* rejected) {
  const int i = (int)get_global_id(0);
  if (i < p.total_cells) porta_pfa_decide_cell(cells, i, &p, sum_map, level_map, rejected);
}

__kernel void pfa_apply(__global porta_keypoint* cells, const porta_pfa p, __global uint* sum_map,
                        __global uint* level_map, __global const uchar* rejected) {
  const int i = (int)get_global_id(0);
  if (i < p.total_cells) porta_pfa_apply_cell(cells, i, &p, sum_map, level_map, rejected);
}

// The steps that `steps` names (bit 0 step A, bit 1 step B, bit 2 step C; uniform) in one
// 1024-wide work-group (GPUs), a barrier between them instead of a launch. Work-item t handles cells
// t, t + 1024, ... in every step, so rejected[i] is written and read by the same work-item; the
// maps the atomics of step A wrote are read by others after the barrier's global fence. The same
// bytes as the three launches. A step left out loops over no cell; its barrier stays (PoCL has
// given wrong bytes and crashed with barriers inside ifs).
#define PORTA_PFA_ALL_STEPS 7
inline void porta_pfa_in_group(__global porta_keypoint* cells, const porta_pfa* p, __global uint* sum_map,
                               __global uint* level_map, __global uchar* rejected, const int steps) {
  const int t = (int)get_local_id(0);
  const int a = (steps & 1) ? p->total_cells : 0, b = (steps & 2) ? p->total_cells : 0;
  const int c = (steps & 4) ? p->total_cells : 0;
  for (int i = t; i < a; i += 1024) porta_pfa_accumulate_cell(cells, i, p, sum_map, level_map);
  barrier(CLK_GLOBAL_MEM_FENCE);
  for (int i = t; i < b; i += 1024) porta_pfa_decide_cell(cells, i, p, sum_map, level_map, rejected);
  barrier(CLK_GLOBAL_MEM_FENCE);  // every read of the maps is done before step C clears them
  for (int i = t; i < c; i += 1024) porta_pfa_apply_cell(cells, i, p, sum_map, level_map, rejected);
}

__kernel __attribute__((reqd_work_group_size(1024, 1, 1)))
void pfa_group(__global porta_keypoint* cells, const porta_pfa p, __global uint* sum_map,
               __global uint* level_map, __global uchar* rejected) {
  porta_pfa_in_group(cells, &p, sum_map, level_map, rejected, PORTA_PFA_ALL_STEPS);
}

// Canonical compaction, step 1 (ARCHITECTURE.md "Keypoint list"): one work-item per block of
// `block` cells; block_count[b] = the number of non-empty cells (response > 0) of block b.
__kernel void compact_count(__global const porta_keypoint* cells, const int total_cells, const int block,
                            __global uint* block_count) {
  const int b = (int)get_global_id(0);
  const int first = b * block;
  if (first >= total_cells) return;
  const int last = min(first + block, total_cells);
  uint count = 0;
  for (int i = first; i < last; ++i) count += cells[i].response != 0 ? 1u : 0u;
  block_count[b] = count;
}

// Compaction, step 2: a single work-item turns block_count into exclusive offsets (in place) and
// writes the total as a little-endian uint32 at count_bytes + count_offset (any alignment).
__kernel void compact_scan(__global uint* block_count, const int num_blocks, __global uchar* count_bytes,
                           const ulong count_offset) {
  if (get_global_id(0) != 0) return;
  uint total = 0;
  for (int b = 0; b < num_blocks; ++b) {
    const uint c = block_count[b];
    block_count[b] = total;
    total += c;
  }
  __global uchar* out = count_bytes + count_offset;
  out[0] = (uchar)(total & 0xFF);
  out[1] = (uchar)((total >> 8) & 0xFF);
  out[2] = (uchar)((total >> 16) & 0xFF);
  out[3] = (uchar)(total >> 24);
}

// Compaction, step 3: one work-item per block writes its non-empty cells, in cell order, from its
// block's offset on; records at or past `capacity` are not written.
__kernel void compact_scatter(__global const porta_keypoint* cells, const int total_cells, const int block,
                              __global const uint* block_offset, __global porta_keypoint* items,
                              const uint capacity) {
  const int b = (int)get_global_id(0);
  const int first = b * block;
  if (first >= total_cells) return;
  const int last = min(first + block, total_cells);
  uint at = block_offset[b];
  for (int i = first; i < last && at < capacity; ++i) {
    const porta_keypoint kp = cells[i];
    if (kp.response == 0) continue;
    items[at++] = kp;
  }
}

// Compaction by one work-group of `width` work-items (`sums`: `width` uints of local memory): the
// same output as compact_count / compact_scan / compact_scatter. The cells go by in tiles of
// 4 * width: each work-item counts its 4 cells, an inclusive prefix sum over the work-group in
// local memory gives where they go, then it writes them (records at or past `capacity` not
// written); the tile's total moves the base on. The count is written as compact_scan writes it.
inline void porta_compact_in_group(__global const porta_keypoint* cells, const int total_cells,
                                   __global porta_keypoint* items, const uint capacity, __global uchar* count_bytes,
                                   const ulong count_offset, __local uint* sums, const int width) {
  const int t = (int)get_local_id(0);
  uint base = 0;
  for (int tile = 0; tile < total_cells; tile += width * 4) {
    const int first = tile + t * 4;
    porta_keypoint kp[4];
    uint count = 0;
    for (int k = 0; k < 4; ++k) {
      kp[k] = first + k < total_cells ? cells[first + k] : porta_cell_keypoint(0, 0, 0, 0);
      count += kp[k].response != 0 ? 1u : 0u;
    }
    sums[t] = count;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int off = 1; off < width; off <<= 1) {
      const uint v = t >= off ? sums[t - off] : 0u;
      barrier(CLK_LOCAL_MEM_FENCE);
      sums[t] += v;
      barrier(CLK_LOCAL_MEM_FENCE);
    }
    uint at = base + sums[t] - count;
    const uint tile_total = sums[width - 1];
    barrier(CLK_LOCAL_MEM_FENCE);  // every work-item has read sums before the next tile writes it
    for (int k = 0; k < 4; ++k) {
      if (kp[k].response == 0) continue;
      if (at < capacity) items[at] = kp[k];
      ++at;
    }
    base += tile_total;
  }
  if (t == 0) {
    __global uchar* out = count_bytes + count_offset;
    out[0] = (uchar)(base & 0xFF);
    out[1] = (uchar)((base >> 8) & 0xFF);
    out[2] = (uchar)((base >> 16) & 0xFF);
    out[3] = (uchar)(base >> 24);
  }
}

// Compaction in one 256-wide work-group (GPUs; compact_count/scan/scatter elsewhere).
__kernel __attribute__((reqd_work_group_size(256, 1, 1)))
void compact_group(__global const porta_keypoint* cells, const int total_cells, __global porta_keypoint* items,
                   const uint capacity, __global uchar* count_bytes, const ulong count_offset) {
  __local uint sums[256];
  porta_compact_in_group(cells, total_cells, items, capacity, count_bytes, count_offset, sums, 256);
}

// §3.3 FAST CRF on GPUs (as fast_crf): one 32 x 8 work-group per tile of any level (`tiles`), one
// launch. The tile and its 3-pixel halo are read into local memory once (clamped to the level: a
// pixel whose circle leaves the level is within `edge` >= 3 of its border and gets 0 without
// reading it), then each work-item tests its pixel's circle there. The same bytes as fast_crf.
__kernel __attribute__((reqd_work_group_size(PORTA_TILE_W, PORTA_TILE_H, 1)))
void fast_tiled(__global const uchar* pyramid, const porta_levels layout, __global const uchar* lut,
                __global ushort* responses, const porta_levels response_layout, const porta_tiles tiles,
                const int eps, const int edge) {
  __local int source[PORTA_TILE_H + 6][PORTA_TILE_W + 6];
  int n;
  int2 origin;
  PORTA_TILE_OF(tiles, layout.count, (int)get_group_id(0), n, origin);
  if (n < 0) return;  // the whole work-group
  const porta_plane src = layout.level[n];
  const int tx = (int)get_local_id(0), ty = (int)get_local_id(1);
  for (int k = ty * PORTA_TILE_W + tx; k < (PORTA_TILE_H + 6) * (PORTA_TILE_W + 6); k += PORTA_TILE_W * PORTA_TILE_H) {
    const int r = k / (PORTA_TILE_W + 6), c = k - r * (PORTA_TILE_W + 6);
    const int sy = clamp(origin.y - 3 + r, 0, src.height - 1);
    const int sx = clamp(origin.x - 3 + c, 0, src.width - 1);
    source[r][c] = pyramid[src.offset_bytes + (long)sy * src.pitch + sx];
  }
  barrier(CLK_LOCAL_MEM_FENCE);
  const int x = origin.x + tx, y = origin.y + ty;
  if (x >= src.width || y >= src.height) return;
  ushort response = 0;
  if (y >= edge && y < src.height - edge && x >= edge && x < src.width - edge) {
    const int c = source[ty + 3][tx + 3];
    uint bright = 0, dark = 0;
    int sum = 0;
    for (int i = 0; i < 16; ++i) {
      const int p = source[ty + 3 + porta_fast_dy[i]][tx + 3 + porta_fast_dx[i]];
      if (p > c + eps) bright |= 1u << i;
      if (p < c - eps) dark |= 1u << i;
      sum += abs(p - c);
    }
    if (lut[bright] | lut[dark]) response = (ushort)sum;
  }
  const porta_plane dst = response_layout.level[n];
  __global ushort* out = (__global ushort*)((__global uchar*)responses + dst.offset_bytes);
  out[(long)y * dst.pitch + x] = response;
}

// §3.3 and §3.4 fused on GPUs (the backend's detect_keypoints): FAST on the cells' pixels straight
// from the pyramid, each cell's maximum kept, no response plane between them. The work split is
// checks::CellGroups, in the grid's first_group and group_shift: a 256-wide work-group holds
// 256 >> group_shift cells of one level, 1 << group_shift work-items each (a 32 x 32 cell takes the
// whole group, four pixels per work-item; 8 x 8 cells sixteen to a group). The key
// (response << 32) | ~(row-major index in the cell) and its maximum are cull_cells_group's; the
// pixels within `edge` of the border have response 0, as fast_crf gives them. The same cell
// records as fast_crf then cull_cells. With `accumulate`, each cell's keypoint also does §3.5 PFA's
// step A (porta_pfa_accumulate_cell: atomics that commute) into the level-0 maps, so that PFA
// needs no launch of its own for it.
__kernel __attribute__((reqd_work_group_size(256, 1, 1)))
void fast_cull_group(__global const uchar* pyramid, const porta_levels layout, __global const uchar* lut,
                     const porta_cells grid, const int eps, const int edge, __global porta_keypoint* out,
                     const int accumulate, const porta_pfa pfa, __global uint* sum_map,
                     __global uint* level_map) {
  __local ulong best[256];
  const int group = (int)get_group_id(0);
  const int lid = (int)get_local_id(0);
  int n = 0;  // the last level whose groups start at or before this one (empty levels have none)
  for (int i = 1; i < grid.count; ++i)
    if (group >= grid.level[i].first_group) n = i;
  const porta_level_cells g = grid.level[n];
  const porta_plane src = layout.level[n];
  const int shift = g.group_shift;  // uniform over the group
  const int slot = lid >> shift, lane = lid & ((1 << shift) - 1);
  const int index = (group - g.first_group) * (256 >> shift) + slot;
  const bool active = index < g.cols * g.rows;
  ulong key = 0;
  int x0 = 0, y0 = 0, w = 1;
  if (active) {
    const int cy = index / g.cols, cx = index - cy * g.cols;
    x0 = cx * g.cell_w;
    y0 = cy * g.cell_h;
    w = min(x0 + g.cell_w, src.width) - x0;
    const int h = min(y0 + g.cell_h, src.height) - y0;
    for (int i = lane; i < w * h; i += 1 << shift) {
      const int dy = i / w;
      const int x = x0 + i - dy * w, y = y0 + dy;
      if (y < edge || y >= src.height - edge || x < edge || x >= src.width - edge) continue;
      const ulong r =
          (ulong)porta_fast_response(pyramid + src.offset_bytes + (long)y * src.pitch + x, src.pitch, lut, eps);
      const ulong k = (r << 32) | (ulong)(0xFFFFFFFFu - (uint)i);
      key = r > 0 && k > key ? k : key;
    }
  }
  // Each cell's work-items are contiguous: a tree over the lanes of every slot at once.
  best[lid] = key;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int stride = (1 << shift) >> 1; stride > 0; stride >>= 1) {
    if (lane < stride && best[lid + stride] > best[lid]) best[lid] = best[lid + stride];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lane != 0 || !active) return;
  const ulong k = best[lid];
  const ushort r = (ushort)(k >> 32);
  const int i = (int)(0xFFFFFFFFu - (uint)(k & 0xFFFFFFFFul));
  const porta_keypoint kp =
      r > 0 ? porta_cell_keypoint(r, x0 + i % w, y0 + i / w, n) : porta_cell_keypoint(0, 0, 0, 0);
  out[g.first_cell + index] = kp;
  if (accumulate && porta_pfa_keypoint(kp, &pfa)) {  // porta_pfa_accumulate_cell
    const uint l = porta_pfa_location(kp, pfa.scales, pfa.width0, pfa.height0);
    atomic_add(&sum_map[l], (uint)kp.response);
    atomic_or(&level_map[l], 1u << kp.level);
  }
}

// §3.5 and the compaction in one 1024-wide work-group (GPUs; the backend's detect_keypoints): the
// PFA steps that pfa_steps names (porta_pfa_in_group; the steps before them ran elsewhere:
// fast_cull_group's step A, pfa_decide's step B), a barrier, then compact_group's scan with 1024
// work-items. Steps A and B loop over every cell in one work-group, so the backend gives them to it
// only for a few hundred cells; step C and the scan, any number. The same bytes as pfa_filter then
// compact_keypoints.
__kernel __attribute__((reqd_work_group_size(1024, 1, 1)))
void pfa_compact_group(__global porta_keypoint* cells, const int pfa_steps, const porta_pfa p,
                       __global uint* sum_map, __global uint* level_map, __global uchar* rejected,
                       const int total_cells, __global porta_keypoint* items, const uint capacity,
                       __global uchar* count_bytes, const ulong count_offset) {
  __local uint sums[1024];
  porta_pfa_in_group(cells, &p, sum_map, level_map, rejected, pfa_steps);
  barrier(CLK_GLOBAL_MEM_FENCE);  // the cleared cells are read by other work-items below
  porta_compact_in_group(cells, total_cells, items, capacity, count_bytes, count_offset, sums, 1024);
}
