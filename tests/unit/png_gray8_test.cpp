// imageio/'s fast reader of 8-bit gray PNG files (png_gray8.hpp) against libpng on the same files:
// what it takes it must read to libpng's bytes, and every file it declines (another format, or
// anything malformed) must be read, or refused with the message, exactly as libpng alone does.
#if PORTA_TESTS_HAVE_PNG

#include <gtest/gtest.h>
#include <png.h>
#include <unistd.h>
#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "imageio/png_file.hpp"
#include "imageio/png_gray8.hpp"

namespace porta {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

void put32(Bytes& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

void put_chunk(Bytes& out, const char* type, const Bytes& data) {
  put32(out, static_cast<std::uint32_t>(data.size()));
  Bytes body(type, type + 4);
  body.insert(body.end(), data.begin(), data.end());
  out.insert(out.end(), body.begin(), body.end());
  put32(out, static_cast<std::uint32_t>(crc32(0, body.data(), static_cast<uInt>(body.size()))));
}

Bytes header_data(std::uint32_t width, std::uint32_t height, int depth = 8, int colour = 0, int interlace = 0) {
  Bytes d;
  put32(d, width);
  put32(d, height);
  d.insert(d.end(), {static_cast<std::uint8_t>(depth), static_cast<std::uint8_t>(colour), 0, 0,
                     static_cast<std::uint8_t>(interlace)});
  return d;
}

Bytes zlib_stream(const Bytes& raw, int window_bits = 15) {
  z_stream z{};
  EXPECT_EQ(deflateInit2(&z, 6, Z_DEFLATED, window_bits, 8, Z_DEFAULT_STRATEGY), Z_OK);
  Bytes out(deflateBound(&z, static_cast<uLong>(raw.size())));
  z.next_in = const_cast<Bytef*>(raw.data());
  z.avail_in = static_cast<uInt>(raw.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

/// Filtered rows (a filter byte, then the row) of a textured `width` x `height` image: the filter
/// of row y is filters[y % filters.size()], each applied as the PNG specification defines it.
Bytes filtered_rows(int width, int height, const std::vector<int>& filters, std::vector<std::uint8_t>* pixels) {
  std::vector<std::uint8_t> image(static_cast<std::size_t>(width) * height);
  std::uint32_t state = 12345;
  for (std::size_t i = 0; i < image.size(); ++i) {
    state = state * 1664525u + 1013904223u;
    const int x = static_cast<int>(i % width), y = static_cast<int>(i / width);
    image[i] = static_cast<std::uint8_t>((x * 3 + y * 2) / 4 + (state >> 28));  // gradient + noise
  }
  if (pixels != nullptr) *pixels = image;
  Bytes out;
  for (int y = 0; y < height; ++y) {
    const int f = filters[static_cast<std::size_t>(y) % filters.size()];
    out.push_back(static_cast<std::uint8_t>(f));
    for (int x = 0; x < width; ++x) {
      const int a = x > 0 ? image[y * width + x - 1] : 0, b = y > 0 ? image[(y - 1) * width + x] : 0;
      const int c = x > 0 && y > 0 ? image[(y - 1) * width + x - 1] : 0;
      const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
      const int paeth = pa <= pb && pa <= pc ? a : (pb <= pc ? b : c);
      const int predictor[5] = {0, a, b, (a + b) / 2, paeth};
      out.push_back(static_cast<std::uint8_t>(image[y * width + x] - predictor[f % 5]));
    }
  }
  return out;
}

/// A PNG file: IHDR, the stream split into IDAT chunks of `idat_bytes`, `extra` chunks before
/// the first IDAT, IEND.
Bytes png_file(const Bytes& ihdr, const Bytes& stream, std::size_t idat_bytes = 8192) {
  Bytes out = {137, 80, 78, 71, 13, 10, 26, 10};
  put_chunk(out, "IHDR", ihdr);
  for (std::size_t at = 0; at < stream.size(); at += idat_bytes)
    put_chunk(out, "IDAT", Bytes(stream.begin() + static_cast<long>(at),
                                 stream.begin() + static_cast<long>(std::min(stream.size(), at + idat_bytes))));
  put_chunk(out, "IEND", {});
  return out;
}

class PngGray8Test : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("porta_png_gray8_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const Bytes& bytes) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                static_cast<std::streamsize>(bytes.size()));
    return path;
  }

  // read_png_gray() must do what libpng alone does: the same pixels, or the same refusal.
  static void expect_as_libpng(const std::string& path, int max_side = 4096) {
    SCOPED_TRACE(path);
    std::string ours_error, libpng_error;
    io::GrayPng ours, theirs;
    try {
      ours = io::read_png_gray(path, max_side);
    } catch (const io::PngError& e) {
      ours_error = std::to_string(static_cast<int>(e.kind())) + " " + e.what();
    }
    try {
      theirs = io::detail::read_png_gray_with_libpng(path, max_side);
    } catch (const io::PngError& e) {
      libpng_error = std::to_string(static_cast<int>(e.kind())) + " " + e.what();
    }
    EXPECT_EQ(ours_error, libpng_error);
    ASSERT_EQ(ours.gray.width(), theirs.gray.width());
    ASSERT_EQ(ours.gray.height(), theirs.gray.height());
    const std::size_t n = static_cast<std::size_t>(ours.gray.width()) * ours.gray.height();
    EXPECT_TRUE(n == 0 || std::memcmp(ours.gray.data(), theirs.gray.data(), n) == 0) << "pixels differ from libpng's";
    EXPECT_EQ(ours.conversion, theirs.conversion);
  }

  // Whether the fast reader takes the file (and then gives `expected`, when given).
  static bool taken(const Bytes& file, const std::vector<std::uint8_t>* expected = nullptr) {
    Image out;
    if (!io::detail::decode_gray8(file.data(), file.size(), 4096, out)) return false;
    if (expected != nullptr) {
      EXPECT_EQ(static_cast<std::size_t>(out.width()) * out.height(), expected->size());
      EXPECT_EQ(std::memcmp(out.data(), expected->data(), expected->size()), 0) << "pixels differ from the image";
    }
    return true;
  }

  fs::path dir_;
};

TEST_F(PngGray8Test, EveryRowFilterIsUndoneToTheImage) {
  // Rows cycling through None, Sub, Up, Average and Paeth, the first row of each too.
  for (const std::vector<int>& filters : std::vector<std::vector<int>>{{0}, {1}, {2}, {3}, {4}, {0, 1, 2, 3, 4}}) {
    SCOPED_TRACE("filters starting with " + std::to_string(filters[0]) + ", " + std::to_string(filters.size()));
    std::vector<std::uint8_t> image;
    const Bytes file = png_file(header_data(301, 157), zlib_stream(filtered_rows(301, 157, filters, &image)));
    EXPECT_EQ(taken(file, &image), io::detail::have_gray8_decoder());
    expect_as_libpng(write("filters.png", file));
  }
}

TEST_F(PngGray8Test, FilesLibpngWritesReadAsLibpngReadsThem) {
  // libpng's own encoder with every filter heuristic, many IDAT chunks, one image per level.
  for (const int level : {0, 1, 6, 9}) {
    const std::string path = (dir_ / ("libpng" + std::to_string(level) + ".png")).string();
    std::vector<std::uint8_t> image;
    filtered_rows(640, 96, {0}, &image);
    std::FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    png_init_io(png, f);
    png_set_compression_level(png, level);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_ALL_FILTERS);
    png_set_IHDR(png, info, 640, 96, 8, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_text text{};
    text.compression = PNG_TEXT_COMPRESSION_NONE;
    text.key = const_cast<char*>("Comment");
    text.text = const_cast<char*>("an ancillary chunk the reader skips");
    png_set_text(png, info, &text, 1);
    png_write_info(png, info);
    for (int y = 0; y < 96; ++y) png_write_row(png, image.data() + y * 640);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
    std::ifstream in(path, std::ios::binary);
    const Bytes file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(taken(file, &image), io::detail::have_gray8_decoder()) << "level " << level;
    expect_as_libpng(path);
  }
}

TEST_F(PngGray8Test, OtherFormatsAreLeftToLibpng) {
  const Bytes rows = filtered_rows(200, 120, {1}, nullptr);
  const std::vector<std::pair<std::string, Bytes>> cases = {
      {"interlaced", png_file(header_data(200, 120, 8, 0, 1), zlib_stream(rows))},
      {"16-bit", png_file(header_data(100, 120, 16), zlib_stream(rows))},
      {"gray+alpha", png_file(header_data(100, 120, 8, 4), zlib_stream(rows))},
      {"small window", png_file(header_data(200, 120), zlib_stream(rows, 9))},
      {"too large", png_file(header_data(5000, 120), zlib_stream(rows))},
  };
  for (const auto& [name, file] : cases) {
    SCOPED_TRACE(name);
    EXPECT_FALSE(taken(file));
    expect_as_libpng(write(name + ".png", file));
  }
}

TEST_F(PngGray8Test, MalformedFilesAreReadOrRefusedAsLibpngDoes) {
  std::vector<std::uint8_t> image;
  const Bytes rows = filtered_rows(200, 120, {4}, &image);
  const Bytes stream = zlib_stream(rows);
  const Bytes good = png_file(header_data(200, 120), stream);
  ASSERT_EQ(taken(good, &image), io::detail::have_gray8_decoder());

  std::vector<std::pair<std::string, Bytes>> cases;
  Bytes bad_crc = good;
  bad_crc[good.size() - 30] ^= 0x40;  // inside the last IDAT's data
  cases.push_back({"IDAT CRC", bad_crc});
  cases.push_back({"truncated", Bytes(good.begin(), good.begin() + static_cast<long>(good.size() / 2))});
  cases.push_back({"no IEND", Bytes(good.begin(), good.end() - 12)});
  Bytes bad_filter = rows;
  bad_filter[(201) * 7] = 5;  // row 7's filter byte
  cases.push_back({"filter 5", png_file(header_data(200, 120), zlib_stream(bad_filter))});
  cases.push_back({"rows short", png_file(header_data(200, 121), stream)});
  cases.push_back({"rows long", png_file(header_data(200, 119), stream)});
  Bytes trailing = stream;
  trailing.insert(trailing.end(), {1, 2, 3, 4});
  cases.push_back({"after the stream", png_file(header_data(200, 120), trailing)});
  Bytes bad_adler = stream;
  bad_adler.back() ^= 1;
  cases.push_back({"Adler-32", png_file(header_data(200, 120), bad_adler)});
  {  // IDAT, then an ancillary chunk, then IDAT again
    Bytes split = {137, 80, 78, 71, 13, 10, 26, 10};
    put_chunk(split, "IHDR", header_data(200, 120));
    put_chunk(split, "IDAT", Bytes(stream.begin(), stream.begin() + 100));
    put_chunk(split, "tEXt", Bytes{'a', 0, 'b'});
    put_chunk(split, "IDAT", Bytes(stream.begin() + 100, stream.end()));
    put_chunk(split, "IEND", {});
    cases.push_back({"IDAT split", split});
  }
  {  // an unknown critical chunk
    Bytes unknown = {137, 80, 78, 71, 13, 10, 26, 10};
    put_chunk(unknown, "IHDR", header_data(200, 120));
    put_chunk(unknown, "XYZW", Bytes{1, 2});
    put_chunk(unknown, "IDAT", stream);
    put_chunk(unknown, "IEND", {});
    cases.push_back({"critical chunk", unknown});
  }
  for (const auto& [name, file] : cases) {
    SCOPED_TRACE(name);
    EXPECT_FALSE(taken(file));
    expect_as_libpng(write("malformed.png", file));
  }
}

TEST_F(PngGray8Test, AncillaryChunksAroundTheDataAreSkipped) {
  std::vector<std::uint8_t> image;
  const Bytes stream = zlib_stream(filtered_rows(200, 120, {2, 3}, &image));
  Bytes file = {137, 80, 78, 71, 13, 10, 26, 10};
  put_chunk(file, "IHDR", header_data(200, 120));
  put_chunk(file, "gAMA", Bytes{0, 0, 0xb1, 0x8f});
  put_chunk(file, "IDAT", stream);
  put_chunk(file, "tEXt", Bytes{'k', 0, 'v'});
  put_chunk(file, "IEND", {});
  EXPECT_EQ(taken(file, &image), io::detail::have_gray8_decoder());
  expect_as_libpng(write("ancillary.png", file));
}

}  // namespace
}  // namespace porta

#endif  // PORTA_TESTS_HAVE_PNG
