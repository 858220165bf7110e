// Where each pyramid level, response map and table lives inside one device buffer.
// Every backend uses these layouts, so bytes can be compared between backends (DESIGN.md §3, §5).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace porta {

/// One 2-D plane inside a buffer: `offset_bytes` to its first element, `pitch` in elements.
struct Plane {
  std::int64_t offset_bytes = 0;
  int width = 0;
  int height = 0;
  int pitch = 0;
};

/// The levels of a pyramid of `element_bytes`-sized elements, packed level after level into one
/// buffer. Level pitches are rounded up to `kPitchAlign` elements.
struct PyramidLayout {
  static constexpr int kPitchAlign = 64;
  std::vector<Plane> levels;
  int element_bytes = 1;
  std::int64_t total_bytes = 0;

  int num_levels() const { return static_cast<int>(levels.size()); }
  /// Lays out levels of the given sizes. `level0_pitch` 0 means aligned like the others.
  static PyramidLayout make(const std::vector<std::pair<int, int>>& sizes, int element_bytes,
                            int level0_pitch = 0);
};

/// Culling cells of one level: the level is tiled from (0,0) into cells of `cell_w` x `cell_h`
/// pixels (the last row and column of cells may be partial). Cells are numbered row-major, and the
/// level's cells start at `first_cell` in the frame-wide cell array.
struct LevelCells {
  int cell_w = 0;
  int cell_h = 0;
  int cols = 0;
  int rows = 0;
  int first_cell = 0;
  int count() const { return cols * rows; }
};

struct CellLayout {
  std::vector<LevelCells> levels;
  int total_cells = 0;
};

}  // namespace porta
