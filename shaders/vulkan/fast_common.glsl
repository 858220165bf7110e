// The FAST test of §3.3 on the pyramid buffer (fast_crf.comp, fast_cull.comp): the including
// shader declares `pyramid` and `lut` (uint8_t, readable). fast_tiled.comp runs the same test on
// its shared-memory tile.

// The radius-3 Bresenham circle (tables.hpp kFastCircle), clockwise from 12 o'clock.
const int kDx[16] = int[16](0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3, -3, -3, -2, -1);
const int kDy[16] = int[16](-3, -3, -2, -1, 0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3);

// The response of the pixel at byte `centre` of `pyramid` (at least 3 pixels inside its level, rows
// `pitch` bytes apart): sum |I_i - c| over the circle when lut[bright] | lut[dark], else 0 (<= 4080).
// The circle (kDx, kDy) is written out tap by tap: a loop over the constant arrays may leave them
// in each invocation's memory where the driver does not unroll it. Two independent tests per tap,
// as in the contract.
#define PORTA_FAST_TAP(i, dx, dy)                               \
  {                                                             \
    const int q = int(pyramid[centre + (dy) * pitch + (dx)]);   \
    if (q > c + eps) bright |= 1u << (i);                       \
    if (q < c - eps) dark |= 1u << (i);                         \
    sum += abs(q - c);                                          \
  }
uint fast_response(int centre, int pitch, int eps) {
  const int c = int(pyramid[centre]);
  uint bright = 0u, dark = 0u;
  int sum = 0;
  PORTA_FAST_TAP(0, 0, -3)
  PORTA_FAST_TAP(1, 1, -3)
  PORTA_FAST_TAP(2, 2, -2)
  PORTA_FAST_TAP(3, 3, -1)
  PORTA_FAST_TAP(4, 3, 0)
  PORTA_FAST_TAP(5, 3, 1)
  PORTA_FAST_TAP(6, 2, 2)
  PORTA_FAST_TAP(7, 1, 3)
  PORTA_FAST_TAP(8, 0, 3)
  PORTA_FAST_TAP(9, -1, 3)
  PORTA_FAST_TAP(10, -2, 2)
  PORTA_FAST_TAP(11, -3, 1)
  PORTA_FAST_TAP(12, -3, 0)
  PORTA_FAST_TAP(13, -3, -1)
  PORTA_FAST_TAP(14, -2, -2)
  PORTA_FAST_TAP(15, -1, -3)
  return (uint(lut[bright]) | uint(lut[dark])) != 0u ? uint(sum) : 0u;
}
#undef PORTA_FAST_TAP
