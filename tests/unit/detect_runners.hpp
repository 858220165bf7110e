// Runs the cpu backend's fast_crf and cull_cells on host data and returns host results, for the
// detection tests. Buffers start full of stale bytes, so a value the kernel forgot to write shows.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "porta/image.hpp"

namespace porta::test {

/// Per level, row-major width x height (no padding).
using ResponsePlanes = std::vector<std::vector<std::uint16_t>>;

/// fast_crf over `levels` (uploaded as given, no resampling) with `lut`, into a response buffer
/// full of 0xA5A5. `level0_pitch` 0 aligns level 0 like the others; else its pitch in pixels.
inline ResponsePlanes run_fast_crf(cpu::CpuBackend& backend, const std::vector<Image>& levels,
                                   const std::vector<std::uint8_t>& lut, FastParams params,
                                   int level0_pitch = 0) {
  std::vector<std::pair<int, int>> sizes;
  for (const Image& img : levels) sizes.emplace_back(img.width(), img.height());
  const PyramidLayout layout = PyramidLayout::make(sizes, 1, level0_pitch);
  const PyramidLayout response_layout = PyramidLayout::make(sizes, 2, level0_pitch);
  auto pyramid = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  backend.fill(*pyramid, 0, pyramid->size_bytes(), 0x5A);
  for (int n = 0; n < layout.num_levels(); ++n)
    for (int y = 0; y < levels[n].height(); ++y)
      backend.upload(
          *pyramid,
          static_cast<std::size_t>(layout.levels[n].offset_bytes + std::int64_t{y} * layout.levels[n].pitch),
          levels[n].row(y), static_cast<std::size_t>(levels[n].width()));
  auto table = backend.allocate(lut.size());
  backend.upload(*table, 0, lut.data(), lut.size());
  auto responses = backend.allocate(static_cast<std::size_t>(response_layout.total_bytes));
  backend.fill(*responses, 0, responses->size_bytes(), 0xA5);
  backend.fast_crf(*pyramid, layout, *table, *responses, response_layout, params);

  ResponsePlanes out;
  for (const Plane& p : response_layout.levels) {
    std::vector<std::uint16_t> plane(static_cast<std::size_t>(p.width) * static_cast<std::size_t>(p.height));
    for (int y = 0; y < p.height; ++y)
      backend.download(*responses, static_cast<std::size_t>(p.offset_bytes + std::int64_t{y} * p.pitch * 2),
                       plane.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(p.width),
                       static_cast<std::size_t>(p.width) * 2);
    out.push_back(std::move(plane));
  }
  return out;
}

/// cull_cells over `planes` (levels of `sizes`) whose padding holds 0xFFFF, larger than any
/// response, so reading outside a level shows; the cell array starts full of 0xFF bytes.
inline std::vector<Keypoint> run_cull_cells(cpu::CpuBackend& backend,
                                            const std::vector<std::pair<int, int>>& sizes,
                                            const ResponsePlanes& planes, const CellLayout& cells,
                                            int level0_pitch = 0) {
  const PyramidLayout layout = PyramidLayout::make(sizes, 2, level0_pitch);
  auto responses = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  backend.fill(*responses, 0, responses->size_bytes(), 0xFF);
  for (int n = 0; n < layout.num_levels(); ++n) {
    const Plane& p = layout.levels[n];
    for (int y = 0; y < p.height; ++y)
      backend.upload(*responses, static_cast<std::size_t>(p.offset_bytes + std::int64_t{y} * p.pitch * 2),
                     planes[n].data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(p.width),
                     static_cast<std::size_t>(p.width) * 2);
  }
  const auto total = static_cast<std::size_t>(std::max(cells.total_cells, 0));
  auto out = backend.allocate(std::max<std::size_t>(1, total * sizeof(Keypoint)));
  backend.fill(*out, 0, out->size_bytes(), 0xFF);
  backend.cull_cells(*responses, layout, cells, *out);
  std::vector<Keypoint> result(total);
  if (total > 0) backend.download(*out, 0, result.data(), total * sizeof(Keypoint));
  return result;
}

}  // namespace porta::test
