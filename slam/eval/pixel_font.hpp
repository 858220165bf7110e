// A 5x7 pixel font for pictures drawn without OpenCV (the run's top view, top_view.cpp): printable
// ASCII in the classic HD44780-style glyphs, one column per word (bit 0 = the top row, row 6 = the
// baseline), with two rows below the baseline for the descenders of g, j, p, q, y and , ;.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace porta::slam::pixel_font {

inline constexpr int kGlyphWidth = 5;
inline constexpr int kGlyphHeight = 7;  ///< cap height: rows 0 to 6
inline constexpr int kCellHeight = 9;   ///< with the descenders
/// Columns from one glyph's left edge to the next's (one blank column between glyphs).
inline constexpr int kAdvance = kGlyphWidth + 1;

/// The five columns of `c`; a character outside printable ASCII gets '?'.
const std::array<std::uint16_t, 5>& glyph(char c);

/// Width in font pixels of `text` on one line (no trailing blank column).
inline int text_width(std::string_view text) {
  return text.empty() ? 0 : static_cast<int>(text.size()) * kAdvance - 1;
}

}  // namespace porta::slam::pixel_font
