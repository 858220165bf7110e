// Definitions shared by every PortaSLAM OpenCL kernel (OpenCL C 1.2). The structs mirror
// engine/include/porta/keypoint.hpp and layout.hpp byte for byte; host mirrors live in
// backends/opencl/cl_types.hpp.

#define PORTA_MAX_LEVELS 12

// One 2-D plane inside a buffer: byte offset, size, pitch in elements (layout.hpp Plane).
typedef struct {
  int offset_bytes;
  int width;
  int height;
  int pitch;
} porta_plane;

// All levels of a pyramid, passed by value.
typedef struct {
  porta_plane level[PORTA_MAX_LEVELS];
  int count;
  int pad[3];
} porta_levels;

// Culling cells of all levels (layout.hpp LevelCells), passed by value.
typedef struct {
  int cell_w;
  int cell_h;
  int cols;
  int rows;
  int first_cell;
  int pad[3];
} porta_level_cells;

typedef struct {
  porta_level_cells level[PORTA_MAX_LEVELS];
  int count;
  int total_cells;
  int pad[2];
} porta_cells;

// A keypoint (keypoint.hpp Keypoint), 8 bytes.
typedef struct {
  ushort x;
  ushort y;
  ushort response;
  uchar level;
  uchar angle_bin;
} porta_keypoint;

// Per-level int tables passed by value (scales, radii, offsets).
typedef struct {
  int v[PORTA_MAX_LEVELS];
} porta_level_ints;

inline int porta_reflect101(int i, int n) {
  if (n == 1) return 0;
  const int period = 2 * n - 2;
  i = i < 0 ? -i : i;
  i %= period;
  return i < n ? i : period - i;
}
