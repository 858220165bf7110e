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
  int first_group;  // fast_cull_group's work split (checks::CellGroups); 0 elsewhere
  int group_shift;
  int pad;
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

// Tiles of PORTA_TILE_W x PORTA_TILE_H pixels over every level of a pyramid, numbered level by
// level (porta/kernel_checks.hpp LevelTiles), passed by value: level n owns work-groups
// [first[n], first[n + 1]), across[n] of them per row of tiles.
#define PORTA_TILE_W 32
#define PORTA_TILE_H 8
typedef struct {
  int first[PORTA_MAX_LEVELS + 4];  // count + 1 entries used
  int across[PORTA_MAX_LEVELS];
} porta_tiles;

// Sets `level` to the level of work-group `tile` (-1 past the last level) and `origin` to the
// tile's top-left pixel, reading the kernel argument `tiles` in place (a macro: through a pointer,
// the argument would be copied to private memory).
#define PORTA_TILE_OF(tiles, count, tile, level, origin)                                             \
  {                                                                                                  \
    level = -1;                                                                                      \
    origin = (int2)(0, 0);                                                                           \
    for (int n_ = 0; n_ < (count); ++n_) {                                                           \
      if ((tile) < tiles.first[n_ + 1]) {                                                            \
        const int k_ = (tile) - tiles.first[n_];                                                     \
        origin = (int2)((k_ % tiles.across[n_]) * PORTA_TILE_W, (k_ / tiles.across[n_]) * PORTA_TILE_H); \
        level = n_;                                                                                  \
        break;                                                                                       \
      }                                                                                              \
    }                                                                                                \
  }
