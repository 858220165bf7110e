// The built-in input of `portaslam features`: a synthetic rectified stereo pair with a known
// disparity at every left pixel, so a fresh user sees the frontend work (and be right) without
// any data. Deterministic: the same bytes on every machine and every run.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "porta/image.hpp"

namespace porta::app {

struct SyntheticStereoPair {
  Image left;
  Image right;
  std::vector<std::uint8_t> disparity_px;  ///< true disparity of each left pixel, row-major
  int min_disparity_px = 0;
  int max_disparity_px = 0;
  std::string description;

  int disparity_at(int x, int y) const { return disparity_px[static_cast<std::size_t>(y) * left.width() + x]; }
};

/// 640x480: a textured background plane and textured rectangles in front of it, each a
/// fronto-parallel plane with its own integer disparity; right(x, y) shows the scene point that
/// the left image shows at (x + d, y), with occlusions handled layer by layer.
SyntheticStereoPair make_synthetic_stereo_pair();

}  // namespace porta::app
