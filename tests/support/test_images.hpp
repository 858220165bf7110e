// Synthetic test images and helpers for kernel tests.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "porta/image.hpp"

namespace porta::test {

/// Uniform random pixels from a fixed seed (the same image on every machine).
Image random_image(int width, int height, std::uint64_t seed, int pitch_bytes = 0);
/// All pixels `value`.
Image flat_image(int width, int height, std::uint8_t value, int pitch_bytes = 0);
/// Squares of `square` px alternating 0 and 255.
Image checkerboard(int width, int height, int square, int pitch_bytes = 0);
/// Smooth random texture (value noise over several octaves): natural-looking, corner-rich.
Image textured_image(int width, int height, std::uint64_t seed, int pitch_bytes = 0);
/// `src` shifted right by `dx` px (negative: left); columns entering repeat the border column.
Image shifted_right(const Image& src, int dx);
/// Loads a grayscale image (with OpenCV, or with libpng through imageio/ where OpenCV is absent: PNG
/// only, colour converted with OpenCV's weights); throws
/// std::runtime_error when it cannot be read or when this build has no image loader.
Image load_gray(const std::string& path);
/// Why load_gray() cannot work in this build (built without OpenCV and libpng), or empty when it can.
std::string image_loading_unavailable_reason();

}  // namespace porta::test
