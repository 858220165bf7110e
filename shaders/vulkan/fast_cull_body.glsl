// The body of fast_cull.comp and fast_cull_finish.comp (which defines FAST_CULL_FINISH); include
// it after common.glsl, with GL_EXT_shader_explicit_arithmetic_types_int64.

// §3.3 and §3.4 fused on GPUs (the backend's detect_keypoints): FAST (fast_crf.comp's test) on the
// cells' pixels straight from the pyramid, each cell's maximum kept, no response plane between them.
// The work split is checks::CellGroups, in the grid's first_group and group_shift: a 256-wide
// workgroup holds 256 >> group_shift cells of one level, 1 << group_shift invocations each (a
// 32 x 32 cell takes the whole workgroup, four pixels per invocation; 8 x 8 cells sixteen to a
// workgroup). The key (response << 32) | ~(row-major index in the cell) and its maximum are
// cull_cells.comp's, reduced through shared memory (no subgroup operations, so any subgroup size
// gives the same bytes); pixels within `edge` of the border have response 0, as fast_crf gives
// them. The same cell records as fast_crf then cull_cells. With `accumulate`, each cell's keypoint
// also does §3.5 PFA's step A (pfa_accumulate_cell: its response and level bit into the level-0
// maps at its L, atomics that commute), so that PFA needs no dispatch of its own for it.
#define GROUP 256
layout(local_size_x = GROUP) in;

layout(std430, set = 0, binding = 0) readonly buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Lut { uint8_t lut[]; };
#ifdef FAST_CULL_FINISH
// The last workgroup reads the cells and maps the others wrote.
layout(std430, set = 0, binding = 2) coherent buffer CellsBuffer { uvec2 cells[]; };
#define cells_out cells
layout(std430, set = 0, binding = 3) coherent buffer SumMap { uint sum_map[]; };
layout(std430, set = 0, binding = 4) coherent buffer LevelMap { uint level_map[]; };
layout(std430, set = 0, binding = 5) buffer Rejected { uint8_t rejected[]; };
layout(std430, set = 0, binding = 6) writeonly buffer Items { uvec2 items[]; };
layout(std430, set = 0, binding = 7) writeonly buffer Count { uint8_t count_bytes[]; };
layout(std430, set = 0, binding = 8) coherent buffer Control { uint finished_groups; };
#else
layout(std430, set = 0, binding = 2) writeonly buffer Out { uvec2 cells_out[]; };
layout(std430, set = 0, binding = 3) buffer SumMap { uint sum_map[]; };
layout(std430, set = 0, binding = 4) buffer LevelMap { uint level_map[]; };
#endif
layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  Cells cells;
  int eps;
  int edge;
  int pad0;
  int pad1;
  // PFA's step A (PfaStepParams' fields), when accumulate != 0.
  int scales[PORTA_MAX_LEVELS];
  int num_scales;
  int width0;
  int height0;
  int accumulate;
#ifdef FAST_CULL_FINISH
  int reach;          // PFA's q / 2
  int total_cells;    // every cell, for PFA's steps B and C and the compaction
  uint pfa_steps;     // 2 | 4 with PFA (steps B and C), 0 without
  uint capacity;      // the compaction's, as pfa_compact_group.comp's
  uint count_offset;
  int pad2;
  int pad3;
  int pad4;
#endif
} p;

#include "fast_common.glsl"
#include "pfa_location.glsl"
#ifdef FAST_CULL_FINISH
#define PFA_DECLARED
#include "pfa_common.glsl"
#define COMPACT_THREADS 256u
#include "compact_in_group.glsl"
shared bool last_group;
#endif

shared uint64_t best[GROUP];

void main() {
  const int group = int(porta_linear_group());
  int n = 0;  // the last level whose workgroups start at or before this one (empty levels have none)
  for (int i = 1; i < p.cells.count; ++i)
    if (group >= p.cells.level[i].first_group) n = i;
  const LevelCells grid = p.cells.level[n];
  const Plane s = p.layout_.level[n];
  const int shift = grid.group_shift;  // uniform over the workgroup
  const int lid = int(gl_LocalInvocationID.x);
  const int slot = lid >> shift, lane = lid & ((1 << shift) - 1);
  const int index = (group - grid.first_group) * (GROUP >> shift) + slot;
  const bool in_grid = index < grid.cols * grid.rows;

  uint64_t key = 0ul;
  int x0 = 0, y0 = 0, w = 1;
  if (in_grid) {
    const int cell_y = index / grid.cols;
    const int cell_x = index - cell_y * grid.cols;
    y0 = cell_y * grid.cell_h;
    x0 = cell_x * grid.cell_w;
    w = min(x0 + grid.cell_w, s.width) - x0;
    const int h = min(y0 + grid.cell_h, s.height) - y0;
    // Pixel i of the cell is (i % w, i / w), the divisions done once: each step moves the
    // invocation 1 << shift pixels on, step_dy rows and step_dx columns.
    const int step = 1 << shift;
    const int step_dy = step / w, step_dx = step - step_dy * w;
    int dy = lane / w, dx = lane - dy * w;
    for (int i = lane; i < w * h; i += step) {
      const int x = x0 + dx, y = y0 + dy;
      dx += step_dx;
      dy += step_dy;
      if (dx >= w) {
        dx -= w;
        ++dy;
      }
      if (y < p.edge || y >= s.height - p.edge || x < p.edge || x >= s.width - p.edge) continue;
      const uint r = fast_response(s.offset_bytes + y * s.pitch + x, s.pitch, p.eps);
      const uint64_t k = (uint64_t(r) << 32) | uint64_t(0xFFFFFFFFu - uint(i));
      key = r > 0u && k > key ? k : key;
    }
  }
  // Each cell's invocations are contiguous: a tree over the lanes of every slot at once.
  best[lid] = key;
  barrier();
  for (int stride = (1 << shift) >> 1; stride > 0; stride >>= 1) {
    if (lane < stride) {
      const uint64_t other = best[lid + stride];
      if (other > best[lid]) best[lid] = other;
    }
    barrier();
  }
  if (lane == 0 && in_grid) {
    const uint64_t k = best[lid];
    const uint r = uint(k >> 32);
    uvec2 kp = uvec2(0u);
    if (r > 0u) {
      const int i = int(0xFFFFFFFFu - uint(k & 0xFFFFFFFFul));
      kp = make_keypoint(uint(x0 + i % w), uint(y0 + i / w), r, uint(n), 0u);
      if (p.accumulate != 0 && n < p.num_scales) {  // pfa_accumulate_cell
        const uint l = pfa_location(kp);
        atomicAdd(sum_map[l], r);
        atomicOr(level_map[l], 1u << uint(n));
      }
    }
    cells_out[grid.first_cell + index] = kp;
  }
#ifdef FAST_CULL_FINISH
  // The workgroup that finishes last (an atomic count of finished workgroups; every invocation's
  // writes made visible before its workgroup counts) runs PFA's steps B and C and the compaction
  // over all cells, as pfa_compact_group.comp does with 1024 invocations, and resets the count for
  // the next dispatch. No workgroup waits for another.
  memoryBarrierBuffer();
  barrier();
  if (lid == 0) {
    const uint groups = gl_NumWorkGroups.x * gl_NumWorkGroups.y * gl_NumWorkGroups.z;
    last_group = atomicAdd(finished_groups, 1u) == groups - 1u;
  }
  barrier();
  if (!last_group) return;  // the whole workgroup
  memoryBarrierBuffer();
  if (lid == 0) finished_groups = 0u;
  const uint total = uint(p.total_cells), t = uint(lid);
  if ((p.pfa_steps & 2u) != 0u) {
    for (uint i = t; i < total; i += GROUP) pfa_decide_cell(i);
    memoryBarrierBuffer();
    barrier();  // every read of the maps is done before step C clears them
  }
  if ((p.pfa_steps & 4u) != 0u) {
    for (uint i = t; i < total; i += GROUP) pfa_apply_cell(i);
    memoryBarrierBuffer();
    barrier();  // the cleared cells are read by other invocations below
  }
  compact_in_group(total, p.capacity, p.count_offset);
#endif
}
