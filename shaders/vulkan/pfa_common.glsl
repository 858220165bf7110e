// Shared by the three steps of §3.5 PFA (DESIGN.md §3.5, backends/cpu/detect_kernels.cpp): one
// invocation per cell each, the same parameters and buffers. `sum_map` and `level_map` are
// level-0 sized scratch planes, all zero before step A (step C restores that).
// Needs GL_EXT_shader_explicit_arithmetic_types_int64 (the projection is 64-bit, as on the cpu).
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) buffer CellsBuffer { uvec2 cells[]; };
layout(std430, set = 0, binding = 1) buffer SumMap { uint sum_map[]; };
layout(std430, set = 0, binding = 2) buffer LevelMap { uint level_map[]; };
layout(std430, set = 0, binding = 3) buffer Rejected { uint8_t rejected[]; };
layout(std430, push_constant) uniform Params {
  int scales[PORTA_MAX_LEVELS];  // S[n], Q16
  int total_cells;
  int num_scales;
  int width0;
  int height0;
  int reach;  // q / 2
} p;

// The keypoint of cell i when it is one PFA looks at (response > 0, a level with a scale).
bool pfa_keypoint(uint i, out uvec2 kp) {
  kp = cells[i];
  return kp_response(kp) != 0u && int(kp_level(kp)) < p.num_scales;
}

// L = Y * width0 + X with X = (x * S[level]) >> 16 and Y likewise, clamped to the level-0 image
// (64-bit products of the sign-extended scale, as the cpu backend).
uint pfa_location(uvec2 kp) {
  const uint64_t scale = uint64_t(int64_t(p.scales[kp_level(kp)]));
  const uint64_t x = min((uint64_t(kp_x(kp)) * scale) >> 16, uint64_t(p.width0 - 1));
  const uint64_t y = min((uint64_t(kp_y(kp)) * scale) >> 16, uint64_t(p.height0 - 1));
  return uint(y * uint64_t(p.width0) + x);
}

// score(L) = (sum of responses at L) * (number of distinct levels at L), in uint32 as the cpu.
uint pfa_score(uint l) { return sum_map[l] * uint(bitCount(level_map[l])); }
