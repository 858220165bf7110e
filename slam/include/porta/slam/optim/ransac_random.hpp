// The random numbers of the RANSAC solvers (rigid_alignment.hpp, pnp.hpp). Results must be
// bit-identical for the same input and seed on every platform, so neither std::random_device nor the
// std:: distributions (whose output is implementation-defined) are used: a SplitMix64 generator
// (Steele, Lea, Flood 2014; the constants of Vigna's reference) and unbiased integer sampling on top,
// plus the adaptive iteration count the two solvers share.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>

namespace porta::slam::optim {

/// SplitMix64: a 64-bit state advanced by a Weyl increment, output through a bijective mixer.
/// Every seed (0 included) gives a full-period sequence.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}

  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ull;
    std::uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

  /// Uniform in [0, n), exactly (no modulo bias): draws below 2^64 mod n are rejected, so the
  /// accepted range is a whole number of copies of [0, n). Throws std::invalid_argument for n == 0.
  std::size_t uniform_index(std::size_t n) {
    if (n == 0) throw std::invalid_argument("SplitMix64::uniform_index: n must be >= 1");
    const std::uint64_t bound = n;
    const std::uint64_t reject_below = (0 - bound) % bound;  // 2^64 mod n
    std::uint64_t x = next();
    while (x < reject_below) x = next();
    return static_cast<std::size_t>(x % bound);
  }

 private:
  std::uint64_t state_;
};

/// Fills `out` with out.size() distinct indices in [0, n), each k-subset equally likely (redrawing
/// duplicates; meant for the small minimal sets of RANSAC, O(k^2)). Throws std::invalid_argument
/// when out.size() > n.
inline void sample_distinct_indices(SplitMix64& rng, std::size_t n, std::span<std::size_t> out) {
  if (out.size() > n) throw std::invalid_argument("sample_distinct_indices: more indices asked than exist");
  for (std::size_t k = 0; k < out.size(); ++k) {
    bool duplicate = true;
    while (duplicate) {
      out[k] = rng.uniform_index(n);
      duplicate = false;
      for (std::size_t j = 0; j < k; ++j) duplicate = duplicate || out[j] == out[k];
    }
  }
}

/// RANSAC's adaptive stopping rule: the number of iterations after which a sample of `sample_size`
/// inliers has been drawn at least once with `probability`, when a fraction `inlier_ratio` of the
/// data are inliers: log(1 - p) / log(1 - w^s), rounded up, clamped to [1, max_iterations].
inline int ransac_required_iterations(double probability, double inlier_ratio, int sample_size,
                                      int max_iterations) {
  const double all_inliers = std::pow(std::clamp(inlier_ratio, 0.0, 1.0), sample_size);
  if (all_inliers >= 1.0) return 1;
  const double denominator = std::log1p(-all_inliers);  // log1p keeps tiny w^s from rounding to 0
  if (!(denominator < 0.0)) return max_iterations;
  const double needed = std::ceil(std::log1p(-probability) / denominator);
  if (!(needed < static_cast<double>(max_iterations))) return max_iterations;
  return std::max(1, static_cast<int>(needed));
}

}  // namespace porta::slam::optim
