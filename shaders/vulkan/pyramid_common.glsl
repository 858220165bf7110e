// §3.2 pyramid (DESIGN.md §3.2, backends/cpu/image_kernels.cpp), shared by build_pyramid.comp
// (8 x 8 workgroups, CPU devices) and build_pyramid_wide.comp (32 x 8, GPUs: a warp writes 32
// consecutive bytes of a row): one level from the level above, one invocation per destination pixel. table[table_offset..] holds cols.src0, cols.w1 (W),
// rows.src0, rows.w1 (H) of this level (ResizeTables::packed); the value is
// (wy0 * (wx0 * p00 + wx1 * p10) + wy1 * (wx0 * p01 + wx1 * p11) + 2^21) >> 22 with 11-bit weights
// (at most 2048 * 2048 * 255 + 2^21 < 2^32: no overflow in uint).
layout(std430, set = 0, binding = 0) buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Table { int table[]; };
layout(std430, push_constant) uniform Params {
  Plane above;
  Plane level;
  int table_offset;
} p;

void main() {
  const int j = int(gl_GlobalInvocationID.x);
  const int i = int(gl_GlobalInvocationID.y);
  if (j >= p.level.width || i >= p.level.height) return;
  const int col_src0 = p.table_offset;
  const int col_w1 = col_src0 + p.level.width;
  const int row_src0 = col_w1 + p.level.width;
  const int row_w1 = row_src0 + p.level.height;

  const int y0 = table[row_src0 + i];
  const int y1 = min(y0 + 1, p.above.height - 1);
  const uint wy1 = uint(table[row_w1 + i]);
  const uint wy0 = 2048u - wy1;
  const int x0 = table[col_src0 + j];
  const int x1 = min(x0 + 1, p.above.width - 1);
  const uint wx1 = uint(table[col_w1 + j]);
  const uint wx0 = 2048u - wx1;
  const int top = p.above.offset_bytes + y0 * p.above.pitch;
  const int bottom = p.above.offset_bytes + y1 * p.above.pitch;
  const uint sum = wy0 * (wx0 * uint(pyramid[top + x0]) + wx1 * uint(pyramid[top + x1])) +
                   wy1 * (wx0 * uint(pyramid[bottom + x0]) + wx1 * uint(pyramid[bottom + x1]));
  pyramid[p.level.offset_bytes + i * p.level.pitch + j] = uint8_t((sum + (1u << 21)) >> 22);
}
