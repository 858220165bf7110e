// Fuzz target: PNG decoding through our image I/O (imageio/png_file.hpp), as every dataset reader
// and `portaslam features` use it. Documented failure: io::PngError.
#include "fuzz_input.hpp"
#include "imageio/png_file.hpp"
#include "porta/settings.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace porta;
  const std::string path = fuzz::write_input(fuzz::scratch_folder() / "input.png", fuzz::as_span(data, size));
  try {
    // A small side limit keeps each execution fast; the check itself is what is fuzzed.
    const io::GrayPng png = io::read_png_gray(path, 2048);
    if (png.gray.width() <= 0 || png.gray.height() <= 0) __builtin_trap();
  } catch (const io::PngError& e) {
    porta::fuzz::expected(e);
  }
  return 0;
}
