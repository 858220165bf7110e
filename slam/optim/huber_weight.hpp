// The Huber loss as our Levenberg-Marquardt loops apply it (private to porta_optim): as g2o and
// Ceres do for Huber, a residual block of squared norm chi2 is weighted by rho'(chi2).
#pragma once

#include <cmath>

namespace porta::slam::optim::detail {

/// Weight rho'(chi2) (1 inside the width, sqrt(delta2 / chi2) outside) and cost 0.5 rho(chi2), for
/// a Huber loss of width sqrt(delta2); without `robust`, the plain squares.
struct HuberWeight {
  double weight = 1.0;
  double cost = 0.0;
};
inline HuberWeight huber_weight(double chi2, double delta2, bool robust) {
  if (!robust || chi2 <= delta2) return {1.0, 0.5 * chi2};
  const double root = std::sqrt(chi2);
  return {std::sqrt(delta2) / root, 0.5 * (2.0 * std::sqrt(delta2) * root - delta2)};
}

}  // namespace porta::slam::optim::detail
