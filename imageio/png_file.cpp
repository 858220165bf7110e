#include "imageio/png_file.hpp"

#include <sys/stat.h>

#include <png.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <vector>

#include "imageio/png_gray8.hpp"

namespace porta::io {

namespace {

constexpr std::size_t kSignatureBytes = 8;

// The libpng reader of one file. libpng reports errors by longjmp to the last setjmp; the two
// functions that setjmp (read_header, read_pixels) hold no object with a destructor, so no
// destructor is ever skipped, and everything is released here.
struct Reader {
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  char message[256] = "";

  ~Reader() {
    if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    if (file) std::fclose(file);
  }
};

void on_error(png_structp png, png_const_charp message) {
  auto* reader = static_cast<Reader*>(png_get_error_ptr(png));
  std::snprintf(reader->message, sizeof reader->message, "%s", message);
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}  // e.g. "iCCP: known incorrect sRGB profile"

// The file's header, and the row layout after the transforms set in read_header().
struct Layout {
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0;     // of the file
  int color_type = 0;    // of the file
  int channels = 0;      // per pixel after the transforms: 1 (gray) or 3 (RGB); 2 or 4 if alpha stayed
  int sample_bytes = 0;  // 1 or 2 (16-bit, big-endian) after the transforms
  std::size_t row_bytes = 0;
};

bool read_header(Reader& r, Layout& layout) {
  if (setjmp(png_jmpbuf(r.png))) return false;
  png_init_io(r.png, r.file);
  png_set_sig_bytes(r.png, static_cast<int>(kSignatureBytes));
  png_read_info(r.png, r.info);
  layout.width = png_get_image_width(r.png, r.info);
  layout.height = png_get_image_height(r.png, r.info);
  layout.bit_depth = png_get_bit_depth(r.png, r.info);
  layout.color_type = png_get_color_type(r.png, r.info);
  if (layout.color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(r.png);
  if (layout.color_type == PNG_COLOR_TYPE_GRAY && layout.bit_depth < 8) png_set_expand_gray_1_2_4_to_8(r.png);
  png_set_strip_alpha(r.png);  // alpha, and palette tRNS that palette_to_rgb expands, are ignored
  png_set_interlace_handling(r.png);
  png_read_update_info(r.png, r.info);
  layout.channels = png_get_channels(r.png, r.info);
  layout.sample_bytes = png_get_bit_depth(r.png, r.info) == 16 ? 2 : 1;
  layout.row_bytes = png_get_rowbytes(r.png, r.info);
  return true;
}

bool read_pixels(Reader& r, png_bytep* rows) {
  if (setjmp(png_jmpbuf(r.png))) return false;
  png_read_image(r.png, rows);
  png_read_end(r.png, nullptr);
  return true;
}

std::string corrupt_detail(const Reader& r) {
  return std::string("corrupt or truncated PNG (libpng: ") + (r.message[0] ? r.message : "unknown error") + ")";
}

// (v + 128) / 257 == round(v / 257) for every 16-bit v (no ties: v / 257 is never k + 1/2).
std::uint8_t sample(const std::uint8_t* p, int sample_bytes) {
  if (sample_bytes == 1) return *p;
  const unsigned v = (static_cast<unsigned>(p[0]) << 8) | p[1];
  return static_cast<std::uint8_t>((v + 128) / 257);
}

// OpenCV 4's RGB2Gray<uchar>: 15-bit fixed-point BT.601 weights that add up to 2^15.
std::uint8_t rgb_to_gray(unsigned r, unsigned g, unsigned b) {
  return static_cast<std::uint8_t>((9798 * r + 19235 * g + 3735 * b + (1u << 14)) >> 15);
}

std::string conversion_of(const Layout& layout) {
  std::string c;
  auto add = [&c](const std::string& what) { c += (c.empty() ? "" : ", ") + what; };
  if (layout.bit_depth == 16) add("16-bit to 8-bit");
  if (layout.bit_depth < 8) add(std::to_string(layout.bit_depth) + "-bit to 8-bit");
  switch (layout.color_type) {
    case PNG_COLOR_TYPE_RGB:
      add("3-channel color to gray");
      break;
    case PNG_COLOR_TYPE_RGB_ALPHA:
      add("4-channel color to gray (alpha dropped)");
      break;
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      add("gray+alpha to gray (alpha dropped)");
      break;
    case PNG_COLOR_TYPE_PALETTE:
      add("palette color to gray");
      break;
    default:
      break;
  }
  return c;
}

}  // namespace

bool has_png_signature(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) return false;
  png_byte signature[kSignatureBytes];
  const std::size_t got = std::fread(signature, 1, kSignatureBytes, file);
  std::fclose(file);
  return got == kSignatureBytes && png_sig_cmp(signature, 0, kSignatureBytes) == 0;
}

namespace {

// The fast reader's try (png_gray8.hpp) on an open file just past its signature: true with the
// image when it took the file; false with the file back where it was, for libpng.
bool read_gray8(std::FILE* file, const png_byte* signature, int max_side, Image& gray) {
  struct stat status {};
  if (fstat(fileno(file), &status) != 0 || status.st_size < static_cast<off_t>(detail::kGray8HeaderBytes)) return false;
  const auto size = static_cast<std::uint64_t>(status.st_size);
  thread_local std::vector<std::uint8_t> bytes;  // the file, kept per thread as png_gray8.cpp's buffers
  if (bytes.capacity() > detail::kKeptBufferBytes) bytes = {};
  bytes.resize(detail::kGray8HeaderBytes);
  std::memcpy(bytes.data(), signature, kSignatureBytes);
  bool taken = false;
  if (std::fread(bytes.data() + kSignatureBytes, 1, bytes.size() - kSignatureBytes, file) ==
          bytes.size() - kSignatureBytes &&
      detail::gray8_worth_reading(bytes.data(), size, max_side)) {
    bytes.resize(static_cast<std::size_t>(size));
    const std::size_t rest = bytes.size() - detail::kGray8HeaderBytes;
    taken = std::fread(bytes.data() + detail::kGray8HeaderBytes, 1, rest, file) == rest &&
            detail::decode_gray8(bytes.data(), bytes.size(), max_side, gray);
  }
  if (!taken) {
    std::clearerr(file);
    if (std::fseek(file, static_cast<long>(kSignatureBytes), SEEK_SET) != 0)
      throw PngError(PngError::Kind::unreadable, std::strerror(errno));
  }
  return taken;
}

GrayPng read_png(const std::string& path, int max_side, bool gray8_first) {
  Reader r;
  r.file = std::fopen(path.c_str(), "rb");
  if (!r.file) throw PngError(PngError::Kind::unreadable, std::strerror(errno));
  png_byte signature[kSignatureBytes];
  const std::size_t got = std::fread(signature, 1, kSignatureBytes, r.file);
  if (got == 0) throw PngError(PngError::Kind::not_png, "empty file, not a PNG");
  if (got < kSignatureBytes || png_sig_cmp(signature, 0, kSignatureBytes) != 0)
    throw PngError(PngError::Kind::not_png, "not a PNG file (no PNG signature)");
  if (gray8_first && detail::have_gray8_decoder()) {
    GrayPng fast;
    if (read_gray8(r.file, signature, max_side, fast.gray)) return fast;
  }

  r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r, on_error, on_warning);
  if (r.png) r.info = png_create_info_struct(r.png);
  if (!r.png || !r.info) throw PngError(PngError::Kind::corrupt, "libpng could not start (out of memory)");

  Layout layout;
  if (!read_header(r, layout)) throw PngError(PngError::Kind::corrupt, corrupt_detail(r));
  const int width = static_cast<int>(layout.width), height = static_cast<int>(layout.height);
  if (layout.width > static_cast<png_uint_32>(max_side) || layout.height > static_cast<png_uint_32>(max_side))
    throw PngError(PngError::Kind::too_large,
                   std::to_string(layout.width) + "x" + std::to_string(layout.height) + " is larger than " +
                       std::to_string(max_side) + " px per side",
                   width, height);

  std::vector<png_byte> pixels(layout.row_bytes * layout.height);
  std::vector<png_bytep> rows(layout.height);
  for (png_uint_32 y = 0; y < layout.height; ++y) rows[y] = pixels.data() + y * layout.row_bytes;
  if (!read_pixels(r, rows.data())) throw PngError(PngError::Kind::corrupt, corrupt_detail(r));

  GrayPng out;
  out.gray = Image(width, height);
  out.conversion = conversion_of(layout);
  const int step = layout.channels * layout.sample_bytes;
  for (int y = 0; y < height; ++y) {
    const png_byte* in = rows[static_cast<std::size_t>(y)];
    std::uint8_t* dst = out.gray.row(y);
    for (int x = 0; x < width; ++x, in += step) {
      if (layout.channels < 3) {
        dst[x] = sample(in, layout.sample_bytes);
      } else {
        const int s = layout.sample_bytes;
        dst[x] = rgb_to_gray(sample(in, s), sample(in + s, s), sample(in + 2 * s, s));
      }
    }
  }
  return out;
}

}  // namespace

GrayPng read_png_gray(const std::string& path, int max_side) { return read_png(path, max_side, true); }

GrayPng detail::read_png_gray_with_libpng(const std::string& path, int max_side) {
  return read_png(path, max_side, false);
}

namespace {

/// A file is written whole or not at all: into a temporary beside `path`, renamed over it once
/// complete; on failure the temporary is removed and an existing `path` is left as it was.
class TemporaryBeside {
 public:
  explicit TemporaryBeside(const std::string& path)
      : path_(path), temporary_(path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter_++)) {}
  ~TemporaryBeside() {
    if (!committed_) std::remove(temporary_.c_str());
  }
  const std::string& path() const { return temporary_; }
  void commit() {
    if (std::rename(temporary_.c_str(), path_.c_str()) != 0)
      throw PngError(PngError::Kind::unwritable, std::string("renaming the finished file failed: ") + std::strerror(errno));
    committed_ = true;
  }

 private:
  static inline std::atomic<unsigned long long> counter_{0};
  std::string path_, temporary_;
  bool committed_ = false;
};

}  // namespace

void write_png_rgb(const std::string& path, int width, int height, const std::uint8_t* rgb,
                   std::size_t stride_bytes) {
  TemporaryBeside file(path);
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB;
  if (!png_image_write_to_file(&image, file.path().c_str(), 0, rgb, static_cast<png_int_32>(stride_bytes), nullptr)) {
    const std::string why = image.message;
    png_image_free(&image);
    throw PngError(PngError::Kind::unwritable, why.empty() ? "libpng could not write it" : why);
  }
  file.commit();
}

namespace {

// The libpng writer of one file (see Reader: the function that setjmps holds no object with a destructor).
struct Writer {
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  char message[256] = "";

  ~Writer() {
    if (png) png_destroy_write_struct(&png, info ? &info : nullptr);
    if (file) std::fclose(file);
  }
};

void on_write_error(png_structp png, png_const_charp message) {
  auto* writer = static_cast<Writer*>(png_get_error_ptr(png));
  std::snprintf(writer->message, sizeof writer->message, "%s", message);
  png_longjmp(png, 1);
}

bool write_gray_rows(Writer& w, int width, int height, const std::uint8_t* gray, std::size_t stride_bytes, int level) {
  if (setjmp(png_jmpbuf(w.png))) return false;
  png_init_io(w.png, w.file);
  png_set_compression_level(w.png, level);
  png_set_filter(w.png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_IHDR(w.png, w.info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, PNG_COLOR_TYPE_GRAY,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
  png_write_info(w.png, w.info);
  for (int y = 0; y < height; ++y)
    png_write_row(w.png, const_cast<png_bytep>(gray + static_cast<std::size_t>(y) * stride_bytes));
  png_write_end(w.png, nullptr);
  return true;
}

}  // namespace

void write_png_gray(const std::string& path, int width, int height, const std::uint8_t* gray, std::size_t stride_bytes,
                    int compression_level) {
  if (width < 1 || height < 1 || compression_level < 0 || compression_level > 9)
    throw PngError(PngError::Kind::unwritable, "bad image size or compression level");
  TemporaryBeside file(path);
  Writer w;
  w.file = std::fopen(file.path().c_str(), "wb");
  if (!w.file) throw PngError(PngError::Kind::unwritable, std::strerror(errno));
  w.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &w, on_write_error, on_warning);
  if (w.png) w.info = png_create_info_struct(w.png);
  if (!w.png || !w.info) throw PngError(PngError::Kind::unwritable, "libpng could not allocate a writer");
  if (!write_gray_rows(w, width, height, gray, stride_bytes, compression_level))
    throw PngError(PngError::Kind::unwritable, std::string("libpng: ") + (w.message[0] ? w.message : "write failed"));
  const bool flushed = std::fflush(w.file) == 0 && !std::ferror(w.file);
  const int error = errno;
  const bool closed = std::fclose(w.file) == 0;
  w.file = nullptr;
  if (!flushed || !closed) throw PngError(PngError::Kind::unwritable, std::strerror(flushed ? errno : error));
  file.commit();
}

}  // namespace porta::io
