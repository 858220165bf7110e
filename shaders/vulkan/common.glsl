// Definitions shared by every PortaSLAM Vulkan compute shader (GLSL 450, SPIR-V for Vulkan 1.1).
// Include it right after `#version` and any #extension lines of the shader. The structs mirror
// backends/vulkan/vk_types.hpp (std430) and engine/include/porta/layout.hpp; see
// backends/vulkan/vulkan_backend.hpp for how a shader is bound and dispatched.
//
// 8-bit and 16-bit values live only in storage buffers (storageBuffer8BitAccess,
// storageBuffer16BitAccess): convert to uint/int on load (uint(x)) and back on store (uint8_t(v));
// no arithmetic on them (that would need shaderInt8/shaderInt16).
#extension GL_EXT_shader_8bit_storage : require
#extension GL_EXT_shader_16bit_storage : require

#define PORTA_MAX_LEVELS 12

// One 2-D plane inside a buffer: byte offset, size, pitch in elements (layout.hpp Plane).
struct Plane {
  int offset_bytes;
  int width;
  int height;
  int pitch;
};

// All levels of a pyramid.
struct Levels {
  Plane level[PORTA_MAX_LEVELS];
  int count;
  int pad0;
  int pad1;
  int pad2;
};

// Culling cells of one level (layout.hpp LevelCells) and of all levels.
struct LevelCells {
  int cell_w;
  int cell_h;
  int cols;
  int rows;
  int first_cell;
  int first_group;  // fast_cull.comp's work split (checks::CellGroups); 0 elsewhere
  int group_shift;
  int pad0;
};

struct Cells {
  LevelCells level[PORTA_MAX_LEVELS];
  int count;
  int total_cells;
  int pad0;
  int pad1;
};

// A Keypoint (keypoint.hpp, 8 bytes) as two little-endian words, so that keypoint arrays need no
// 8/16-bit arithmetic: .x = x | y << 16, .y = response | level << 16 | angle_bin << 24.
uint kp_x(uvec2 k) { return k.x & 0xFFFFu; }
uint kp_y(uvec2 k) { return k.x >> 16; }
uint kp_response(uvec2 k) { return k.y & 0xFFFFu; }
uint kp_level(uvec2 k) { return (k.y >> 16) & 0xFFu; }
uint kp_angle_bin(uvec2 k) { return k.y >> 24; }
uvec2 make_keypoint(uint x, uint y, uint response, uint level, uint angle_bin) {
  return uvec2((x & 0xFFFFu) | (y << 16), (response & 0xFFFFu) | ((level & 0xFFu) << 16) | (angle_bin << 24));
}

// The item of a Work::items dispatch: the host spreads more workgroups than the x limit over y.
// (Macros, because gl_WorkGroupSize may only be used after the shader's local-size declaration.)
#define porta_linear_index() \
  (gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x)
// The item of a Work::groups dispatch (one workgroup per item).
#define porta_linear_group() (gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x)

// Reflect-101 index into [0, n) (tables.hpp reflect101): -1 -> 1, n -> n-2; 0 when n == 1.
int porta_reflect101(int i, int n) {
  if (n == 1) return 0;
  const int period = 2 * n - 2;
  i = i < 0 ? -i : i;
  i %= period;  // both non-negative: % is defined
  return i < n ? i : period - i;
}

// Tiles of PORTA_TILE_W x PORTA_TILE_H pixels over every level of a pyramid, numbered level by
// level (porta/kernel_checks.hpp LevelTiles): level n owns workgroups [first[n], first[n + 1]),
// across[n] of them per row of tiles. Kernels that run all levels in one dispatch, one workgroup
// per tile, find their level and tile origin with PORTA_TILE_OF below.
#define PORTA_TILE_W 32
#define PORTA_TILE_H 8
struct Tiles {
  int first[PORTA_MAX_LEVELS + 4];  // count + 1 entries used
  int across[PORTA_MAX_LEVELS];
};

// Sets `level` to the level of workgroup `tile` (-1 past the last level) and `origin` to the
// tile's top-left pixel, reading `tiles` (a Tiles in the parameter buffer) where it lies: a macro,
// because a function would take its argument by value, a copy of the whole table per invocation.
#define PORTA_TILE_OF(tiles, count, tile, level, origin)                                     \
  {                                                                                          \
    level = -1;                                                                              \
    origin = ivec2(0);                                                                       \
    for (int n_ = 0; n_ < (count); ++n_) {                                                   \
      if ((tile) < tiles.first[n_ + 1]) {                                                    \
        const int k_ = (tile) - tiles.first[n_];                                             \
        origin = ivec2((k_ % tiles.across[n_]) * PORTA_TILE_W, (k_ / tiles.across[n_]) * PORTA_TILE_H); \
        level = n_;                                                                          \
        break;                                                                               \
      }                                                                                      \
    }                                                                                        \
  }
