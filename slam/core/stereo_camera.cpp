#include "porta/slam/stereo_camera.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "porta/settings.hpp"

namespace porta::slam {

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("stereo camera: " + what);
}

}  // namespace

void StereoCamera::validate() const {
  require(width >= 1 && width <= kMaxImageSide,
          "width " + std::to_string(width) + " is outside [1, " + std::to_string(kMaxImageSide) + "]");
  require(height >= 1 && height <= kMaxImageSide,
          "height " + std::to_string(height) + " is outside [1, " + std::to_string(kMaxImageSide) + "]");
  require(std::isfinite(fx) && fx > 0.0, "fx must be a finite number > 0 (got " + std::to_string(fx) + ")");
  require(std::isfinite(fy) && fy > 0.0, "fy must be a finite number > 0 (got " + std::to_string(fy) + ")");
  require(std::isfinite(cx), "cx must be finite");
  require(std::isfinite(cy), "cy must be finite");
  require(std::isfinite(baseline_m) && baseline_m > 0.0,
          "baseline must be a finite number of metres > 0 (got " + std::to_string(baseline_m) + ")");
}

std::string StereoCamera::describe() const {
  char text[160];
  std::snprintf(text, sizeof text, "%dx%d fx %.2f fy %.2f cx %.2f cy %.2f baseline %.4f m", width, height, fx,
                fy, cx, cy, baseline_m);
  return text;
}

}  // namespace porta::slam
