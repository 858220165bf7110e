#include "porta/slam/stereo_camera.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "porta/settings.hpp"

namespace porta::slam {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("stereo camera: " + what);
}

/// Shortest form that still tells 1e300 from 1e-300 (std::to_string gives 0.000000 for the latter).
std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

}  // namespace

void StereoCamera::validate() const {
  require(width >= 1 && width <= kMaxImageSide,
          "width " + std::to_string(width) + " is outside [1, " + std::to_string(kMaxImageSide) + "]");
  require(height >= 1 && height <= kMaxImageSide,
          "height " + std::to_string(height) + " is outside [1, " + std::to_string(kMaxImageSide) + "]");
  // Plausible for any real rectified camera: a field of view between ~0.6 and ~136 degrees
  // across the longer side, the principal point on the image, a baseline from 1 mm to 100 m.
  // Outside these the numbers are a typo, and would overflow pixel arithmetic downstream.
  const double side = std::max(width, height);
  const double f_min = kMinFocalPerSide * side, f_max = kMaxFocalPerSide * side;
  const auto focal = [&](const char* name, double f) {
    std::ostringstream m;
    m << name << " " << number(f) << " is outside [" << number(f_min) << ", " << number(f_max) << "] px for a "
      << width << "x" << height << " image";
    require(std::isfinite(f) && f >= f_min && f <= f_max, m.str());
  };
  focal("fx", fx);
  focal("fy", fy);
  const auto on_image = [&](const char* name, double c, int size) {
    std::ostringstream m;
    m << name << " " << number(c) << " is outside the image, [0, " << size << "]";
    require(std::isfinite(c) && c >= 0.0 && c <= size, m.str());
  };
  on_image("cx", cx, width);
  on_image("cy", cy, height);
  std::ostringstream m;
  m << "baseline " << number(baseline_m) << " m is outside [" << number(kMinBaselineM) << ", " << number(kMaxBaselineM)
    << "] m";
  require(std::isfinite(baseline_m) && baseline_m >= kMinBaselineM && baseline_m <= kMaxBaselineM, m.str());
}

std::string StereoCamera::describe() const {
  char text[160];
  std::snprintf(text, sizeof text, "%dx%d fx %.2f fy %.2f cx %.2f cy %.2f baseline %.4f m", width, height, fx,
                fy, cx, cy, baseline_m);
  return text;
}

}  // namespace porta::slam
