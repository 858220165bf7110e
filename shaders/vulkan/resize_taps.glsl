// §3.2 pyramid: the source pixels and weights of a destination pixel, shared by
// pyramid_common.glsl and build_pyramid_fused.comp; include it after the `table` buffer (the
// packed ResizeTables: cols.src0, cols.w1 (W), rows.src0, rows.w1 (H) of a level from
// table_offset). The value is (wy0 * (wx0 * p00 + wx1 * p10) + wy1 * (wx0 * p01 + wx1 * p11) +
// 2^21) >> 22 with 11-bit weights (at most 2048 * 2048 * 255 + 2^21 < 2^32: no overflow in uint).
struct ResizeTaps {
  int x0, x1, y0, y1;
  uint wx0, wx1, wy0, wy1;
};

ResizeTaps resize_taps(int table_offset, Plane above, Plane level, int x, int y) {
  const int col_src0 = table_offset;
  const int col_w1 = col_src0 + level.width;
  const int row_src0 = col_w1 + level.width;
  const int row_w1 = row_src0 + level.height;
  ResizeTaps t;
  t.y0 = table[row_src0 + y];
  t.y1 = min(t.y0 + 1, above.height - 1);
  t.wy1 = uint(table[row_w1 + y]);
  t.wy0 = 2048u - t.wy1;
  t.x0 = table[col_src0 + x];
  t.x1 = min(t.x0 + 1, above.width - 1);
  t.wx1 = uint(table[col_w1 + x]);
  t.wx0 = 2048u - t.wx1;
  return t;
}

// p00 at (x0, y0), p10 at (x1, y0), p01 at (x0, y1), p11 at (x1, y1).
uint resize_value(ResizeTaps t, uint p00, uint p10, uint p01, uint p11) {
  const uint sum = t.wy0 * (t.wx0 * p00 + t.wx1 * p10) + t.wy1 * (t.wx0 * p01 + t.wx1 * p11);
  return (sum + (1u << 21)) >> 22;
}
