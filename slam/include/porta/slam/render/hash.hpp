// Integer hashing for the renderer: every random choice of the world, the textures and the image
// noise is a pure function of (seed, integer coordinates), so the same arguments give the same
// world and the same bytes whatever the thread count or the order of work.
#pragma once

#include <cstdint>

namespace porta::slam::render {

/// SplitMix64's finaliser: a bijective, well-mixing 64-bit hash.
constexpr std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// Hash of a seed and up to three signed integers (e.g. a world cell and a purpose tag).
constexpr std::uint64_t hash_of(std::uint64_t seed, std::int64_t a, std::int64_t b = 0, std::int64_t c = 0) {
  std::uint64_t h = mix64(seed ^ 0x5851F42D4C957F2Dull);
  h = mix64(h ^ static_cast<std::uint64_t>(a));
  h = mix64(h ^ (static_cast<std::uint64_t>(b) * 0xD6E8FEB86659FD93ull));
  h = mix64(h ^ (static_cast<std::uint64_t>(c) * 0xA0761D6478BD642Full));
  return h;
}

/// Uniform in [0, 1) from the top 53 bits of a hash.
constexpr double unit_of(std::uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

/// A small deterministic generator (SplitMix64 sequence) for loops that need many numbers.
class HashRng {
 public:
  explicit constexpr HashRng(std::uint64_t seed) : state_(seed) {}
  constexpr std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ull;
    return mix64(state_);
  }
  constexpr double uniform() { return unit_of(next()); }
  constexpr double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Integer in [0, n).
  constexpr int below(int n) { return static_cast<int>(next() % static_cast<std::uint64_t>(n)); }

 private:
  std::uint64_t state_;
};

}  // namespace porta::slam::render
