// A rectified stereo camera: two identical pinhole cameras, the right one `baseline_m` along the
// left camera's +x axis (so a point at depth z appears at disparity fx * baseline_m / z pixels).
// Everything after the dataset readers (renderer, frontend, tracking) works in this model; the
// readers rectify raw cameras (EuRoC) into it.
#pragma once

#include <string>

namespace porta::slam {

struct StereoCamera {
  int width = 0;   ///< pixels
  int height = 0;  ///< pixels
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  ///< pixels
  double baseline_m = 0.0;

  /// fx * baseline: disparity (px) = bf / depth (m). ORB-SLAM2's Camera.bf.
  double bf() const { return fx * baseline_m; }
  /// Throws std::invalid_argument naming the field when a value is out of range: sizes 1..16384,
  /// focal lengths > 0 and finite, principal point finite, baseline > 0 and finite.
  void validate() const;
  /// "752x480 fx 458.65 fy 457.30 cx 367.22 cy 248.38 baseline 0.1101 m"
  std::string describe() const;
};

}  // namespace porta::slam
