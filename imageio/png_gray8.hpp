// The fast reader of the commonest PNG file, 8-bit gray and not interlaced (the images of every
// dataset: KITTI, EuRoC, the renderer's), used by read_png_gray() (png_file.hpp) before libpng.
// It takes a file only when every part it relies on checks out: the chunks' CRCs and order, the
// header, the zlib stream's Adler-32 and exact length, the row filters. Any other file, well
// formed or not, is left to libpng, so the bytes read and the messages given are libpng's; this
// reader only gives the same bytes sooner (libdeflate inflates about three times as fast as zlib).
// Internal to imageio/ and its tests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "imageio/png_file.hpp"
#include "porta/image.hpp"

namespace porta::io::detail {

/// The reader's buffers stay with their thread between files up to this size (a 4096x4096 image).
inline constexpr std::size_t kKeptBufferBytes = std::size_t{17} << 20;

/// Whether this build has the fast reader (libdeflate was found when it was configured).
bool have_gray8_decoder();

/// Bytes of a PNG file's start that gray8_worth_reading() needs: signature and IHDR chunk.
inline constexpr std::size_t kGray8HeaderBytes = 33;

/// From a file's first kGray8HeaderBytes bytes and its size: whether decode_gray8() may take it
/// (an 8-bit gray, non-interlaced PNG of at most `max_side` per side, and a file no larger than
/// its pixels could plausibly compress to, so that reading it whole into memory is bounded).
bool gray8_worth_reading(const std::uint8_t* header, std::uint64_t file_size, int max_side);

/// Decodes a whole PNG file (signature included) into `out` and returns true when the file is one
/// gray8_worth_reading() accepts and is well formed in every part checked; otherwise returns false
/// and leaves `out` as it was. Always false in a build without libdeflate.
bool decode_gray8(const std::uint8_t* file, std::size_t size, int max_side, Image& out);

/// read_png_gray() through libpng alone (png_file.cpp), for tests that compare the two readers.
GrayPng read_png_gray_with_libpng(const std::string& path, int max_side);

}  // namespace porta::io::detail
