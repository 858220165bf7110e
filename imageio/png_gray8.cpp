// 8-bit gray PNG files through libdeflate; see png_gray8.hpp. The format is the PNG specification's
// (ISO/IEC 15948): chunks of length, type, data and CRC-32 over type and data; the image data is
// one zlib stream split over consecutive IDAT chunks; each row starts with its filter type.
#include "imageio/png_gray8.hpp"

#include <cstring>
#include <utility>
#include <vector>

#ifndef PORTA_PNG_HAVE_LIBDEFLATE
#define PORTA_PNG_HAVE_LIBDEFLATE 0
#endif
#if PORTA_PNG_HAVE_LIBDEFLATE
#include <libdeflate.h>
#endif

namespace porta::io::detail {
namespace {

constexpr std::uint8_t kSignature[8] = {137, 80, 78, 71, 13, 10, 26, 10};

std::uint32_t big_endian(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

bool is_type(const std::uint8_t* p, const char (&name)[5]) { return std::memcmp(p, name, 4) == 0; }

/// The IHDR fields this reader takes: 8-bit gray, deflate, adaptive filtering, no interlace.
struct Header {
  std::uint32_t width = 0, height = 0;
};

/// Parses the signature and the first chunk, IHDR (its CRC is checked by decode_gray8 only).
bool parse_header(const std::uint8_t* file, int max_side, Header& h) {
  if (std::memcmp(file, kSignature, sizeof kSignature) != 0) return false;
  const std::uint8_t* chunk = file + 8;
  if (big_endian(chunk) != 13 || !is_type(chunk + 4, "IHDR")) return false;
  const std::uint8_t* d = chunk + 8;
  h.width = big_endian(d);
  h.height = big_endian(d + 4);
  const bool gray8 = d[8] == 8 && d[9] == 0 && d[10] == 0 && d[11] == 0 && d[12] == 0;
  return gray8 && h.width > 0 && h.height > 0 && max_side > 0 && h.width <= static_cast<std::uint32_t>(max_side) &&
         h.height <= static_cast<std::uint32_t>(max_side);
}

std::uint64_t filtered_bytes(const Header& h) { return (std::uint64_t{h.width} + 1) * h.height; }

#if PORTA_PNG_HAVE_LIBDEFLATE

int paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = p > a ? p - a : a - p, pb = p > b ? p - b : b - p, pc = p > c ? p - c : c - p;
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

/// Undoes one row's filter (one byte per pixel); `up` is the row above, nullptr for the first.
bool unfilter_row(int filter, const std::uint8_t* in, const std::uint8_t* up, std::uint8_t* row, std::size_t n) {
  switch (filter) {
    case 0:  // None
      std::memcpy(row, in, n);
      return true;
    case 1:  // Sub
      row[0] = in[0];
      for (std::size_t x = 1; x < n; ++x) row[x] = static_cast<std::uint8_t>(in[x] + row[x - 1]);
      return true;
    case 2:  // Up
      if (up == nullptr) {
        std::memcpy(row, in, n);
      } else {
        for (std::size_t x = 0; x < n; ++x) row[x] = static_cast<std::uint8_t>(in[x] + up[x]);
      }
      return true;
    case 3:  // Average
      for (std::size_t x = 0; x < n; ++x) {
        const int left = x > 0 ? row[x - 1] : 0, above = up != nullptr ? up[x] : 0;
        row[x] = static_cast<std::uint8_t>(in[x] + ((left + above) >> 1));
      }
      return true;
    case 4:  // Paeth
      for (std::size_t x = 0; x < n; ++x) {
        const int left = x > 0 ? row[x - 1] : 0, above = up != nullptr ? up[x] : 0;
        const int corner = x > 0 && up != nullptr ? up[x - 1] : 0;
        row[x] = static_cast<std::uint8_t>(in[x] + paeth(left, above, corner));
      }
      return true;
    default:
      return false;
  }
}

/// The concatenated IDAT data of a file whose chunks all check out; false for anything libpng
/// might treat otherwise (a bad CRC, a misplaced or unknown critical chunk, no IEND).
bool collect_image_data(const std::uint8_t* file, std::size_t size, std::vector<std::uint8_t>& data) {
  std::size_t pos = 8;
  bool first = true, in_data = false, after_data = false;
  while (true) {
    if (size - pos < 12) return false;
    const std::uint32_t length = big_endian(file + pos);
    if (length > 0x7fffffffu || size - pos - 12 < length) return false;
    const std::uint8_t* type = file + pos + 4;
    for (int k = 0; k < 4; ++k) {
      const std::uint8_t c = type[k];
      if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'))) return false;
    }
    const std::uint32_t stored = big_endian(file + pos + 8 + length);
    if (libdeflate_crc32(0, type, std::size_t{length} + 4) != stored) return false;
    const bool critical = (type[0] & 0x20) == 0;
    if (first != is_type(type, "IHDR")) return false;  // IHDR first and only first
    if (is_type(type, "IDAT")) {
      if (after_data) return false;  // IDAT chunks must be consecutive
      data.insert(data.end(), type + 4, type + 4 + length);
      in_data = true;
    } else if (is_type(type, "IEND")) {
      return length == 0 && in_data;
    } else {
      if (critical && !first) return false;  // PLTE (no use in gray) or a critical chunk unknown here
      after_data = after_data || in_data;
    }
    first = false;
    pos += 12 + std::size_t{length};
  }
}

#endif  // PORTA_PNG_HAVE_LIBDEFLATE

}  // namespace

bool have_gray8_decoder() { return PORTA_PNG_HAVE_LIBDEFLATE != 0; }

bool gray8_worth_reading(const std::uint8_t* header, std::uint64_t file_size, int max_side) {
  Header h;
  if (!have_gray8_decoder() || !parse_header(header, max_side, h)) return false;
  // Deflate's stored blocks add 5 bytes per 65 535: a file far beyond the filtered rows' size is
  // not plain image data, and libpng, which streams, reads it without holding it all.
  const std::uint64_t rows = filtered_bytes(h);
  return file_size <= rows + rows / 8 + (std::uint64_t{1} << 20);
}

bool decode_gray8(const std::uint8_t* file, std::size_t size, int max_side, Image& out) {
#if PORTA_PNG_HAVE_LIBDEFLATE
  if (size < kGray8HeaderBytes || !gray8_worth_reading(file, size, max_side)) return false;
  Header h;
  parse_header(file, max_side, h);
  // Kept per thread across files (a dataset reader decodes one pair after another): fresh buffers
  // of this size would be new pages, and faulting them in costs a tenth of the decode.
  // (One of a very large image is let go at the thread's next file.)
  thread_local std::vector<std::uint8_t> data, filtered;
  if (filtered.capacity() > kKeptBufferBytes) filtered = {};
  if (data.capacity() > kKeptBufferBytes) data = {};
  data.clear();
  if (!collect_image_data(file, size, data)) return false;
  // zlib, under libpng, holds a stream to the window its header declares; libdeflate always allows
  // 32 KiB. Only 32-KiB streams are taken (libpng writes them for any image above 16 KiB).
  if (data.size() < 2 || (data[0] >> 4) != 7) return false;

  const std::size_t width = h.width, height = h.height;
  filtered.resize(static_cast<std::size_t>(filtered_bytes(h)));
  libdeflate_decompressor* inflater = libdeflate_alloc_decompressor();
  if (inflater == nullptr) return false;
  std::size_t consumed = 0;
  // The exact size, or it fails; and the stream must fill the IDAT data to its end.
  const libdeflate_result inflated = libdeflate_zlib_decompress_ex(inflater, data.data(), data.size(), filtered.data(),
                                                                   filtered.size(), &consumed, nullptr);
  libdeflate_free_decompressor(inflater);
  if (inflated != LIBDEFLATE_SUCCESS || consumed != data.size()) return false;

  Image gray(static_cast<int>(width), static_cast<int>(height));
  for (std::size_t y = 0; y < height; ++y) {
    const std::uint8_t* in = filtered.data() + y * (width + 1);
    std::uint8_t* row = gray.row(static_cast<int>(y));
    const std::uint8_t* up = y > 0 ? gray.row(static_cast<int>(y) - 1) : nullptr;
    if (!unfilter_row(in[0], in + 1, up, row, width)) return false;
  }
  out = std::move(gray);
  return true;
#else
  (void)file, (void)size, (void)max_side, (void)out;
  return false;
#endif
}

}  // namespace porta::io::detail
