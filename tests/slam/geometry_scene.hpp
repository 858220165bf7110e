// Scene helpers shared by the geometric-solver tests (EPnP, rigid alignment): a KITTI-like camera
// and a platform-independent random source built on the solvers' own SplitMix64.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

#include "porta/slam/optim/ransac_random.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::optim::test {

inline StereoCamera kitti_camera() { return StereoCamera{1242, 375, 718.856, 718.856, 607.19, 185.22, 0.537}; }

struct SceneRng {
  SplitMix64 bits;
  explicit SceneRng(std::uint64_t seed) : bits(seed) {}
  double uniform(double lo, double hi) {  // 53 random mantissa bits, [lo, hi)
    return lo + (hi - lo) * static_cast<double>(bits.next() >> 11) * 0x1.0p-53;
  }
  double gaussian() {  // Box-Muller
    const double u1 = 1.0 - uniform(0.0, 1.0), u2 = uniform(0.0, 1.0);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }
};

inline double deg(double degrees) { return degrees * std::numbers::pi / 180.0; }

}  // namespace porta::slam::optim::test
