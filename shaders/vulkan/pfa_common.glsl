// Shared by the three steps of §3.5 PFA (DESIGN.md §3.5, backends/cpu/detect_kernels.cpp) and by
// pfa_group.comp, which runs all three in one workgroup: the same parameters and buffers, and the
// steps per cell (pfa_accumulate_cell, pfa_decide_cell, pfa_apply_cell). `sum_map` and `level_map`
// are level-0 sized scratch planes, all zero before step A (step C restores that).
// Needs GL_EXT_shader_explicit_arithmetic_types_int64 (the projection is 64-bit, as on the cpu).
// A shader that reads the maps another invocation of its workgroup wrote defines PFA_MAPS as
// `coherent` before including this file (and PFA_CELLS likewise when others read the cells it
// clears); one that needs more push constants after these defines
// PFA_EXTRA_PARAMS as their declarations.
#ifndef PFA_MAPS
#define PFA_MAPS
#endif

#ifndef PFA_CELLS
#define PFA_CELLS
#endif
// A shader that declares the buffers and the parameters `p` itself, under these names, defines
// PFA_DECLARED (fast_cull_finish.comp).
#ifndef PFA_DECLARED
layout(std430, set = 0, binding = 0) PFA_CELLS buffer CellsBuffer { uvec2 cells[]; };
layout(std430, set = 0, binding = 1) PFA_MAPS buffer SumMap { uint sum_map[]; };
layout(std430, set = 0, binding = 2) PFA_MAPS buffer LevelMap { uint level_map[]; };
layout(std430, set = 0, binding = 3) buffer Rejected { uint8_t rejected[]; };
layout(std430, push_constant) uniform Params {
  int scales[PORTA_MAX_LEVELS];  // S[n], Q16
  int total_cells;
  int num_scales;
  int width0;
  int height0;
  int reach;  // q / 2
#ifdef PFA_EXTRA_PARAMS
  PFA_EXTRA_PARAMS
#endif
} p;
#endif

// The keypoint of cell i when it is one PFA looks at (response > 0, a level with a scale).
bool pfa_keypoint(uint i, out uvec2 kp) {
  kp = cells[i];
  return kp_response(kp) != 0u && int(kp_level(kp)) < p.num_scales;
}

#include "pfa_location.glsl"

// score(L) = (sum of responses at L) * (number of distinct levels at L), in uint32 as the cpu.
uint pfa_score(uint l) { return sum_map[l] * uint(bitCount(level_map[l])); }

// Step A: the keypoint of cell i adds its response to sum_map[L] and its level bit to
// level_map[L]. The atomics commute, so the maps do not depend on their order.
void pfa_accumulate_cell(uint i) {
  uvec2 kp;
  if (!pfa_keypoint(i, kp)) return;
  const uint l = pfa_location(kp);
  atomicAdd(sum_map[l], kp_response(kp));
  atomicOr(level_map[l], 1u << kp_level(kp));
}

// Step B: rejected[i] = 1 when a location within `reach` of the keypoint's L (clipped to the
// level-0 image) scores strictly more than L, else 0. Cells and maps are only read.
void pfa_decide_cell(uint i) {
  uvec2 kp;
  uint reject = 0u;
  if (pfa_keypoint(i, kp)) {
    const uint l = pfa_location(kp);
    const uint own = pfa_score(l);
    const int x = int(l % uint(p.width0));
    const int y = int(l / uint(p.width0));
    const int xa = max(0, x - p.reach), xb = min(p.width0 - 1, x + p.reach);
    const int ya = max(0, y - p.reach), yb = min(p.height0 - 1, y + p.reach);
    // Every location of the window is read, with no early exit: the loads go out together.
    for (int wy = ya; wy <= yb; ++wy) {
      const uint row = uint(wy) * uint(p.width0);
      for (int wx = xa; wx <= xb; ++wx) reject |= pfa_score(row + uint(wx)) > own ? 1u : 0u;
    }
  }
  rejected[i] = uint8_t(reject);
}

// Step C: clears the cell if step B rejected it and resets the map entries its keypoint touched
// to 0 (several invocations may write the same 0: benign).
void pfa_apply_cell(uint i) {
  uvec2 kp;
  if (!pfa_keypoint(i, kp)) return;
  const uint l = pfa_location(kp);
  sum_map[l] = 0u;
  level_map[l] = 0u;
  if (uint(rejected[i]) != 0u) cells[i] = uvec2(0u);
}
