#include "porta/layout.hpp"

#include <stdexcept>

namespace porta {

namespace {
int align_up(int v, int a) { return (v + a - 1) / a * a; }
}  // namespace

PyramidLayout PyramidLayout::make(const std::vector<std::pair<int, int>>& sizes, int element_bytes,
                                  int level0_pitch) {
  if (element_bytes <= 0) throw std::invalid_argument("PyramidLayout: element size must be positive");
  PyramidLayout layout;
  layout.element_bytes = element_bytes;
  std::int64_t offset = 0;
  for (std::size_t n = 0; n < sizes.size(); ++n) {
    Plane p;
    p.width = sizes[n].first;
    p.height = sizes[n].second;
    p.pitch = (n == 0 && level0_pitch > 0) ? level0_pitch : align_up(p.width, kPitchAlign);
    if (p.pitch < p.width) throw std::invalid_argument("PyramidLayout: level 0 pitch is smaller than its width");
    p.offset_bytes = offset;
    offset += static_cast<std::int64_t>(p.pitch) * p.height * element_bytes;
    offset = (offset + 255) / 256 * 256;  // each level starts 256-byte aligned
    layout.levels.push_back(p);
  }
  layout.total_bytes = offset;
  return layout;
}

}  // namespace porta
