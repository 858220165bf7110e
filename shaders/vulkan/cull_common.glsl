// Of the workgroup-per-cell culling shader (cull_cells.comp; fast_cull.comp splits its work as
// checks::CellGroups instead): finding a cell and the end of its reduction. The including shader declares its parameter block `p` with
// the grid as `Cells cells`, `cells_out` (uvec2, writable) and the 64-wide workgroup. Needs
// GL_EXT_shader_explicit_arithmetic_types_int64.

// The level whose grid holds frame-wide cell index `cell`, -1 when none does. It reads p.cells in
// place: a Cells passed by value is a copy of every level's grid per invocation, which a dynamic
// index may keep in local memory (suspected where culling ran 3-4x slower on NVIDIA's Vulkan than
// OpenCL's same kernel).
int cull_level_of(int cell) {
  for (int i = 0; i < p.cells.count; ++i) {
    const int first = p.cells.level[i].first_cell;
    if (cell >= first && cell - first < p.cells.level[i].cols * p.cells.level[i].rows) return i;
  }
  return -1;
}

shared uint64_t cull_best[64];

// Each invocation's `key` (response << 32) | ~(row-major index in the cell) reduced to the maximum
// through shared memory (no subgroup operations, so any subgroup size gives the same bytes), and
// that maximum written as the record of `cell` at (x0, y0), `w` pixels wide, of level n (all zero
// when its response is 0). Every invocation of the workgroup calls it.
void cull_write_maximum(uint64_t key, int cell, int x0, int y0, int w, int n) {
  const uint lid = gl_LocalInvocationID.x;
  cull_best[lid] = key;
  barrier();
  for (uint stride = 32u; stride > 0u; stride >>= 1) {
    if (lid < stride) {
      const uint64_t other = cull_best[lid + stride];
      if (other > cull_best[lid]) cull_best[lid] = other;
    }
    barrier();
  }
  if (lid == 0u) {
    const uint64_t k = cull_best[0];
    const uint r = uint(k >> 32);
    uvec2 kp = uvec2(0u);
    if (r > 0u) {
      const int i = int(0xFFFFFFFFu - uint(k & 0xFFFFFFFFul));
      kp = make_keypoint(uint(x0 + i % w), uint(y0 + i / w), r, uint(n), 0u);
    }
    cells_out[cell] = kp;
  }
}
