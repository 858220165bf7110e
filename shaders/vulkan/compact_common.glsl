// Shared by the three steps of the canonical compaction (ARCHITECTURE.md "Keypoint list"): the
// non-empty cells (response > 0) in cell order into `items`, their number as a little-endian
// uint32 at byte `count_offset` of `count_bytes` (any alignment). Blocks of `block` cells.
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer CellsBuffer { uvec2 cells[]; };
layout(std430, set = 0, binding = 1) buffer Blocks { uint block_count[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Items { uvec2 items[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Count { uint8_t count_bytes[]; };
layout(std430, push_constant) uniform Params {
  uint total_cells;
  uint block;
  uint capacity;  // records at or past it are not written
  uint num_blocks;
  uint count_offset;
} p;
