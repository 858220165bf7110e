// Shared by the description and matching shaders (orient, orb_describe, stereo_match_*,
// projection_match): device lists and level-0 positions. Include after common.glsl.
//
// A device list (backend.hpp DeviceList) keeps its length in a little-endian uint32 at byte
// `offset` of a count buffer, which the shaders bind as uint8_t[] so that any offset works. The
// kernels launch over the list's capacity and read the length on the device: slots at or past it
// do nothing. The host never passes an offset outside the count buffer (a list without one gets a
// stand-in buffer and offset 0).
int porta_list_length(uint b0, uint b1, uint b2, uint b3, int capacity) {
  const uint n = b0 | (b1 << 8) | (b2 << 16) | (b3 << 24);
  return capacity <= 0 ? 0 : int(min(n, uint(capacity)));
}
#define PORTA_LIST_LENGTH(bytes, offset, capacity)                                    \
  porta_list_length(uint(bytes[(offset)]), uint(bytes[(offset) + 1u]),                 \
                    uint(bytes[(offset) + 2u]), uint(bytes[(offset) + 3u]), (capacity))

// Level-0 position in 1/256 px of coordinate c at a level of Q16 scale S (contract_math.hpp
// level0_q8): (c * S + 128) >> 8 in uint32, wrapping as the cpu's uint32 product does.
int porta_level0_q8(uint c, int scale_q16) { return int((c * uint(scale_q16) + 128u) >> 8); }
