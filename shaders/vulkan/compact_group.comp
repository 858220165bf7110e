#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

// Compaction in one workgroup (GPUs; compact_count/scan/scatter elsewhere): the same output as
// the three steps, the non-empty cells (response > 0) in cell order into `items` (records at or
// past `capacity` not written) and their number as a little-endian uint32 at byte `count_offset`
// of `count_bytes` (compact_in_group.glsl).
layout(local_size_x = 256) in;

layout(std430, set = 0, binding = 0) readonly buffer CellsBuffer { uvec2 cells[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Items { uvec2 items[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Count { uint8_t count_bytes[]; };
layout(std430, push_constant) uniform Params {
  uint total_cells;
  uint capacity;
  uint count_offset;
} p;

#define COMPACT_THREADS 256u
#include "compact_in_group.glsl"

void main() { compact_in_group(p.total_cells, p.capacity, p.count_offset); }
