// Random test inputs that are the same on every CPU. The arguments of one call are evaluated in an
// unspecified order: GCC evaluates `Vector3d(u(rng), u(rng), u(rng))` last argument first on x86-64
// and first argument first on aarch64, so the same seed gave each CPU different samples (found by
// the aarch64 job, ci/cross-aarch64.sh). Each draw here is its own statement, in x86-64's order, so
// that the samples the tests were tuned on stay exactly those.
#pragma once

#include <Eigen/Core>
#include <random>

namespace porta::slam::test {

/// Three draws of `distribution`, z first, then y, then x.
template <typename Distribution>
Eigen::Vector3d draw_xyz(Distribution& distribution, std::mt19937& rng) {
  const double z = distribution(rng);
  const double y = distribution(rng);
  const double x = distribution(rng);
  return {x, y, z};
}

}  // namespace porta::slam::test
