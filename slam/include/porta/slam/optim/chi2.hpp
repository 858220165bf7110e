// Measurement noise and outlier thresholds shared by the SLAM optimisations (after ORB-SLAM2):
// a keypoint detected on pyramid level n has sigma = scale_factor^n pixels in every coordinate, so
// its information is I / sigma^2, and an observation is an outlier when its chi2 (squared
// whitened residual) exceeds the 95% quantile of the chi-square law with 2 (mono) or 3 (stereo)
// degrees of freedom. The robust (Huber) kernel's width is the square root of the same quantile.
#pragma once

#include <cmath>

namespace porta::slam::optim {

inline constexpr double kChi2Mono95 = 5.991;    ///< chi-square, 2 DoF, 95%
inline constexpr double kChi2Stereo95 = 7.815;  ///< chi-square, 3 DoF, 95%

/// sigma^2 of a keypoint on pyramid level `level` (0 = full resolution): scale_factor^(2 level).
inline double level_sigma2(int level, double scale_factor) {
  return std::pow(scale_factor, 2.0 * static_cast<double>(level));
}

}  // namespace porta::slam::optim
