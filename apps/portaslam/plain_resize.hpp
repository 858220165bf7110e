// Resizing 8-bit gray images without OpenCV, for `portaslam bench` in a build without OpenCV C++:
// the two interpolations the OpenCV build asks cv::resize for, computed the way OpenCV 4's own C++
// code computes them for 8-bit single-channel images (same coefficients, fixed-point formats and
// order of float operations), so that both builds time the frontend on the same bytes. OpenCV
// builds that route cv::resize through IPP or other accelerated code may differ by rounding.
#pragma once

#include "porta/image.hpp"

namespace porta::app {

/// cv::resize(src, dst, {width, height}, 0, 0, INTER_AREA) for shrinking (width <= src.width and
/// height <= src.height): the mean of each destination pixel's footprint, weighted by overlap;
/// integer factors average whole blocks.
Image resize_area(const ImageView& src, int width, int height);

/// cv::resize(src, dst, {width, height}, 0, 0, INTER_LINEAR): bilinear with pixel centres aligned
/// ((x + 0.5) * scale - 0.5), edges clamped, 11-bit fixed-point weights.
Image resize_bilinear(const ImageView& src, int width, int height);

}  // namespace porta::app
