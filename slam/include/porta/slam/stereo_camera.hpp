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
  /// Plausibility bounds of validate(): focal lengths per pixel of the longer image side, baseline.
  static constexpr double kMinFocalPerSide = 0.2, kMaxFocalPerSide = 100.0;
  static constexpr double kMinBaselineM = 1e-3, kMaxBaselineM = 100.0;

  /// Throws std::invalid_argument naming the field, its value and the range when a value is
  /// outside what a real camera has: sizes 1..kMaxImageSide, focal lengths in
  /// [kMinFocalPerSide, kMaxFocalPerSide] x the longer side, the principal point on the image,
  /// baseline in [kMinBaselineM, kMaxBaselineM].
  void validate() const;
  /// "752x480 fx 458.65 fy 457.30 cx 367.22 cy 248.38 baseline 0.1101 m"
  std::string describe() const;
};

}  // namespace porta::slam
