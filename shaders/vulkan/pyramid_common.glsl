// §3.2 pyramid (DESIGN.md §3.2, backends/cpu/image_kernels.cpp), shared by build_pyramid.comp
// (8 x 8 workgroups, CPU devices) and build_pyramid_wide.comp (32 x 8, GPUs: a warp writes 32
// consecutive bytes of a row): one level from the level above, one invocation per destination
// pixel, by resize_taps.glsl.
layout(std430, set = 0, binding = 0) buffer Pyramid { uint8_t pyramid[]; };
layout(std430, set = 0, binding = 1) readonly buffer Table { int table[]; };
layout(std430, push_constant) uniform Params {
  Plane above;
  Plane level;
  int table_offset;
} p;

#include "resize_taps.glsl"

void main() {
  const int j = int(gl_GlobalInvocationID.x);
  const int i = int(gl_GlobalInvocationID.y);
  if (j >= p.level.width || i >= p.level.height) return;
  const ResizeTaps t = resize_taps(p.table_offset, p.above, p.level, j, i);
  const int top = p.above.offset_bytes + t.y0 * p.above.pitch;
  const int bottom = p.above.offset_bytes + t.y1 * p.above.pitch;
  pyramid[p.level.offset_bytes + i * p.level.pitch + j] =
      uint8_t(resize_value(t, uint(pyramid[top + t.x0]), uint(pyramid[top + t.x1]), uint(pyramid[bottom + t.x0]),
                           uint(pyramid[bottom + t.x1])));
}
