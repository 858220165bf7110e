#include "support/test_images.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "porta/settings.hpp"

// Image files are read with OpenCV where the build has it, else with libpng through imageio/ (the
// GPU machine of ci/gpu.sh has no OpenCV), else not at all: tests needing real images then skip,
// saying why.
#if PORTA_TESTS_HAVE_OPENCV
#include <opencv2/imgcodecs.hpp>
#elif PORTA_TESTS_HAVE_PNG
#include "imageio/png_file.hpp"
#endif

namespace porta::test {

namespace {
std::uint64_t next(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
}  // namespace

Image random_image(int width, int height, std::uint64_t seed, int pitch_bytes) {
  Image img(width, height, pitch_bytes);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) img.at(x, y) = static_cast<std::uint8_t>(next(seed) & 0xFF);
  return img;
}

Image flat_image(int width, int height, std::uint8_t value, int pitch_bytes) {
  Image img(width, height, pitch_bytes);
  for (int y = 0; y < height; ++y) std::memset(img.row(y), value, static_cast<std::size_t>(width));
  return img;
}

Image checkerboard(int width, int height, int square, int pitch_bytes) {
  Image img(width, height, pitch_bytes);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) img.at(x, y) = ((x / square + y / square) % 2) ? 255 : 0;
  return img;
}

Image textured_image(int width, int height, std::uint64_t seed, int pitch_bytes) {
  std::vector<double> acc(static_cast<std::size_t>(width) * height, 0.0);
  double amp = 1.0, total = 0.0;
  for (int cell = 64; cell >= 2; cell /= 2, amp *= 0.6) {
    const int gw = width / cell + 2, gh = height / cell + 2;
    std::vector<double> grid(static_cast<std::size_t>(gw) * gh);
    for (auto& g : grid) g = static_cast<double>(next(seed) & 0xFFFF) / 65535.0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const double fx = static_cast<double>(x) / cell, fy = static_cast<double>(y) / cell;
        const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
        const double tx = fx - ix, ty = fy - iy;
        const double sx = tx * tx * (3 - 2 * tx), sy = ty * ty * (3 - 2 * ty);
        const double a = grid[iy * gw + ix], b = grid[iy * gw + ix + 1];
        const double c = grid[(iy + 1) * gw + ix], d = grid[(iy + 1) * gw + ix + 1];
        acc[static_cast<std::size_t>(y) * width + x] += amp * ((a * (1 - sx) + b * sx) * (1 - sy) + (c * (1 - sx) + d * sx) * sy);
      }
    total += amp;
  }
  Image img(width, height, pitch_bytes);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double v = acc[static_cast<std::size_t>(y) * width + x] / total;
      // Stretch contrast around the mean so that corners are plentiful.
      img.at(x, y) = static_cast<std::uint8_t>(std::clamp(std::lround((v - 0.5) * 3.0 * 255.0 + 127.5), 0L, 255L));
    }
  return img;
}

Image shifted_right(const Image& src, int dx) {
  Image out(src.width(), src.height());
  for (int y = 0; y < src.height(); ++y)
    for (int x = 0; x < src.width(); ++x) out.at(x, y) = src.at(std::clamp(x - dx, 0, src.width() - 1), y);
  return out;
}

Image load_gray(const std::string& path) {
#if PORTA_TESTS_HAVE_OPENCV
  cv::Mat m = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (m.empty()) throw std::runtime_error("cannot read image " + path);
  Image img(m.cols, m.rows);
  for (int y = 0; y < m.rows; ++y) std::memcpy(img.row(y), m.ptr(y), static_cast<std::size_t>(m.cols));
  return img;
#elif PORTA_TESTS_HAVE_PNG
  try {
    return io::read_png_gray(path, kMaxImageSide).gray;
  } catch (const io::PngError& e) {
    throw std::runtime_error("cannot read image " + path + ": " + e.what());
  }
#else
  throw std::runtime_error("cannot read image " + path + ": " + image_loading_unavailable_reason());
#endif
}

std::string image_loading_unavailable_reason() {
#if PORTA_TESTS_HAVE_OPENCV || PORTA_TESTS_HAVE_PNG
  return {};
#else
  return "this test build has no image loader (neither OpenCV nor libpng was found at configure time)";
#endif
}

}  // namespace porta::test
