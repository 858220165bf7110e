// The pyramid of DESIGN.md §3.2 written straight from the contract (four taps, 64-bit sums), the
// reference the cpu kernel's tests compare against.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "porta/image.hpp"
#include "porta/tables.hpp"

namespace porta::test {

/// Levels 0..sizes.size()-1 from `image` (level 0, copied): level n from level n - 1 through the
/// host tables, out = (sum wy * wx * p + 2^21) >> 22 over the taps (x0 | x0 + 1 clamped,
/// y0 | y0 + 1 clamped).
inline std::vector<Image> contract_pyramid(const Image& image, const std::vector<std::pair<int, int>>& sizes) {
  const ResizeTables tables = build_resize_tables(sizes);
  std::vector<Image> levels{Image::copy_of(image.view())};
  for (std::size_t n = 1; n < sizes.size(); ++n) {
    const Image& above = levels.back();
    const ResizeAxis& cols = tables.cols[n - 1];
    const ResizeAxis& rows = tables.rows[n - 1];
    Image level(sizes[n].first, sizes[n].second);
    for (int i = 0; i < level.height(); ++i)
      for (int j = 0; j < level.width(); ++j) {
        const int ys[2] = {rows.src0[i], std::min(rows.src0[i] + 1, above.height() - 1)};
        const int xs[2] = {cols.src0[j], std::min(cols.src0[j] + 1, above.width() - 1)};
        const std::int64_t wy[2] = {2048 - rows.w1[i], rows.w1[i]};
        const std::int64_t wx[2] = {2048 - cols.w1[j], cols.w1[j]};
        std::int64_t sum = 1 << 21;
        for (int a = 0; a < 2; ++a)
          for (int b = 0; b < 2; ++b) sum += wy[a] * wx[b] * above.at(xs[b], ys[a]);
        level.at(j, i) = static_cast<std::uint8_t>(sum / (1 << 22));
      }
    levels.push_back(std::move(level));
  }
  return levels;
}

}  // namespace porta::test
