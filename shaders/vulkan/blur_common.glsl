// Shared by blur_horizontal.comp and blur_vertical.comp (§3.7 blur, DESIGN.md §3.7), the blur of
// CPU devices (lavapipe) and of a blur in place: both run one invocation per row of all levels laid
// end to end (Work::items(total rows)), walking the row in a loop, with the same parameters.
// `scratch_offset[n]` is the element index of level n's packed (pitch = width) uint16 plane of
// horizontal sums; `taps` the 7 integer taps summing to 256.
layout(local_size_x = 64) in;

layout(std430, set = 1, binding = 0) readonly buffer Params {
  Levels layout_;
  int scratch_offset[PORTA_MAX_LEVELS];
  int taps[PORTA_MAX_LEVELS];
} p;

// The level of global row `row` (*y: the row within it); -1 past the last level.
int blur_locate_row(int row, out int y) {
  y = 0;
  for (int n = 0; n < p.layout_.count; ++n) {
    const int h = p.layout_.level[n].height;
    if (row < h) {
      y = row;
      return n;
    }
    row -= h;
  }
  return -1;
}
