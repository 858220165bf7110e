// Fuzz target: PNG decoding through our image I/O (imageio/png_file.hpp), as every dataset reader
// and `portaslam features` use it. Documented failure: io::PngError. Differential too: the fast
// 8-bit gray reader (png_gray8.hpp) must give what libpng alone gives, pixels or refusal.
#include <cstring>

#include "fuzz_input.hpp"
#include "imageio/png_file.hpp"
#include "imageio/png_gray8.hpp"
#include "porta/settings.hpp"

namespace {

// The pixels, or the refusal's kind and message, of one reader.
struct Outcome {
  porta::io::GrayPng png;
  std::string error;
};

template <typename Read>
Outcome outcome_of(Read read) {
  Outcome o;
  try {
    o.png = read();
    if (o.png.gray.width() <= 0 || o.png.gray.height() <= 0) __builtin_trap();
  } catch (const porta::io::PngError& e) {
    porta::fuzz::expected(e);
    o.error = std::to_string(static_cast<int>(e.kind())) + e.what();
  }
  return o;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace porta;
  const std::string path = fuzz::write_input(fuzz::scratch_folder() / "input.png", fuzz::as_span(data, size));
  // A small side limit keeps each execution fast; the check itself is what is fuzzed.
  const Outcome ours = outcome_of([&] { return io::read_png_gray(path, 2048); });
  const Outcome libpng = outcome_of([&] { return io::detail::read_png_gray_with_libpng(path, 2048); });
  const Image& a = ours.png.gray;
  const Image& b = libpng.png.gray;
  if (ours.error != libpng.error || a.width() != b.width() || a.height() != b.height() ||
      ours.png.conversion != libpng.png.conversion ||
      (a.width() > 0 && std::memcmp(a.data(), b.data(), static_cast<std::size_t>(a.width()) * a.height()) != 0))
    __builtin_trap();
  return 0;
}
