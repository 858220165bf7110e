// The FAST test of §3.3 on the pyramid buffer (fast_crf.comp, fast_cull.comp): the including
// shader declares `pyramid` and `lut` (uint8_t, readable). fast_tiled.comp runs the same test on
// its shared-memory tile.

// The radius-3 Bresenham circle (tables.hpp kFastCircle), clockwise from 12 o'clock.
const int kDx[16] = int[16](0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3, -3, -3, -2, -1);
const int kDy[16] = int[16](-3, -3, -2, -1, 0, 1, 2, 3, 3, 3, 2, 1, 0, -1, -2, -3);

// The response of the pixel at byte `centre` of `pyramid` (at least 3 pixels inside its level, rows
// `pitch` bytes apart): sum |I_i - c| over the circle when lut[bright] | lut[dark], else 0 (<= 4080).
uint fast_response(int centre, int pitch, int eps) {
  const int c = int(pyramid[centre]);
  uint bright = 0u, dark = 0u;
  int sum = 0;
  for (int i = 0; i < 16; ++i) {
    const int q = int(pyramid[centre + kDy[i] * pitch + kDx[i]]);
    // Two independent tests, as in the contract.
    if (q > c + eps) bright |= 1u << i;
    if (q < c - eps) dark |= 1u << i;
    sum += abs(q - c);
  }
  return (uint(lut[bright]) | uint(lut[dark])) != 0u ? uint(sum) : 0u;
}
