// PNG files through libpng, for code above the engine that must handle image files without
// OpenCV (the portaslam program built without OpenCV C++, the test support library). Reading
// gives 8-bit gray converted exactly as OpenCV's imread(IMREAD_UNCHANGED) + convertTo + cvtColor
// would (the path portaslam takes with OpenCV), so both builds see the same bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "porta/image.hpp"

namespace porta::io {

/// Why a PNG file could not be read or written. what() is the detail only (no file name), e.g.
/// "not a PNG file (no PNG signature)" or "corrupt or truncated PNG (libpng: IDAT: CRC error)":
/// the caller names the file in its own words.
class PngError : public std::runtime_error {
 public:
  enum class Kind {
    unreadable,  ///< the file cannot be opened or read
    not_png,     ///< empty, or no PNG signature
    corrupt,     ///< a PNG signature, but libpng failed to decode it
    too_large,   ///< a side beyond the limit given to read_png_gray(); width/height say the size
    unwritable,  ///< write_png_rgb() failed
  };
  PngError(Kind kind, const std::string& detail, int width = 0, int height = 0)
      : std::runtime_error(detail), kind_(kind), width_(width), height_(height) {}
  Kind kind() const { return kind_; }
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  Kind kind_;
  int width_, height_;
};

struct GrayPng {
  Image gray;              ///< packed (pitch = width)
  std::string conversion;  ///< what was done to make it 8-bit gray, e.g. "16-bit to 8-bit, 3-channel
                           ///< color to gray"; empty when the file already was 8-bit gray
};

/// True when the file at `path` starts with the 8-byte PNG signature (false when unreadable).
bool has_png_signature(const std::string& path);

/// Reads a PNG file as 8-bit gray. Every PNG colour type and bit depth is accepted:
///  - 16-bit samples become round(v / 257) (OpenCV's convertTo(CV_8U, 1 / 257.0));
///  - 1-, 2- and 4-bit gray is expanded to 8 bits (0..255), a palette to its RGB colours;
///  - colour becomes gray as OpenCV 4's cvtColor(COLOR_RGB2GRAY) computes it for 8-bit data:
///    (9798 R + 19235 G + 3735 B + 2^14) >> 15; alpha (and tRNS transparency) is ignored.
/// Images with a side above `max_side` are rejected (Kind::too_large) before any pixel is decoded.
/// Throws PngError.
GrayPng read_png_gray(const std::string& path, int max_side);

/// Writes 8-bit RGB pixels (`width` x `height`, rows `stride_bytes` apart) as a PNG file.
/// Throws PngError (Kind::unwritable) with libpng's reason.
void write_png_rgb(const std::string& path, int width, int height, const std::uint8_t* rgb,
                   std::size_t stride_bytes);

/// Writes 8-bit gray pixels (`width` x `height`, rows `stride_bytes` apart) as a PNG file with fixed
/// settings (zlib level `compression_level` in [0, 9], one fixed row filter, no time stamp), so that
/// the same pixels always give the same bytes with a given libpng and zlib. Level 1 with the "sub"
/// filter is fast and still compresses textured images well. Throws PngError (Kind::unwritable).
void write_png_gray(const std::string& path, int width, int height, const std::uint8_t* gray,
                    std::size_t stride_bytes, int compression_level = 1);

}  // namespace porta::io
