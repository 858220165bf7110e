#include "synthetic_pair.hpp"

#include <algorithm>
#include <cmath>

namespace porta::app {

namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

// A plane of the scene: a rectangle in left-image coordinates (the background covers everything),
// its disparity, and the seed and brightness of its texture.
struct Layer {
  int x0, y0, x1, y1;  // [x0, x1) x [y0, y1)
  int disparity_px;
  std::uint64_t seed;
  double brightness;  // mean grey in [0, 1]

  bool covers(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};

// Back to front, by growing disparity (nearer planes occlude farther ones, as in a real scene).
const Layer kLayers[] = {
    {-1000000, -1000000, 1000000, 1000000, 6, 0x5eed0001u, 0.50},  // background
    {40, 50, 270, 230, 14, 0x5eed0002u, 0.30},
    {200, 180, 420, 330, 18, 0x5eed0006u, 0.55},
    {330, 70, 590, 250, 22, 0x5eed0003u, 0.72},
    {90, 280, 300, 450, 30, 0x5eed0004u, 0.62},
    {380, 300, 600, 440, 40, 0x5eed0005u, 0.38},
};

// A well-mixed 64-bit hash of a lattice point, so the noise needs no stored grid.
std::uint64_t lattice_hash(std::int64_t ix, std::int64_t iy, std::uint64_t seed) {
  std::uint64_t z = seed ^ (static_cast<std::uint64_t>(ix) * 0x9E3779B97F4A7C15ull) ^
                    (static_cast<std::uint64_t>(iy) * 0xC2B2AE3D27D4EB4Full);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double lattice_value(std::int64_t ix, std::int64_t iy, std::uint64_t seed) {
  return static_cast<double>(lattice_hash(ix, iy, seed) >> 11) / static_cast<double>(1ull << 53);
}

// Multi-octave value noise in [0, 1] at integer pixel (x, y) of the plane's own coordinates:
// coarse octaves give blobs, fine ones give the corners FAST finds.
double value_noise(int x, int y, std::uint64_t seed) {
  double sum = 0.0, weight = 0.0, amplitude = 1.0;
  for (int cell = 48, octave = 0; cell >= 3; cell /= 2, ++octave, amplitude *= 0.6) {
    const double fx = (x + 0.5) / cell, fy = (y + 0.5) / cell;
    const auto ix = static_cast<std::int64_t>(std::floor(fx)), iy = static_cast<std::int64_t>(std::floor(fy));
    const double tx = fx - static_cast<double>(ix), ty = fy - static_cast<double>(iy);
    const double sx = tx * tx * (3.0 - 2.0 * tx), sy = ty * ty * (3.0 - 2.0 * ty);
    const std::uint64_t octave_seed = seed + 0x1000u * static_cast<std::uint64_t>(octave);
    const double top = lattice_value(ix, iy, octave_seed) * (1 - sx) + lattice_value(ix + 1, iy, octave_seed) * sx;
    const double bottom =
        lattice_value(ix, iy + 1, octave_seed) * (1 - sx) + lattice_value(ix + 1, iy + 1, octave_seed) * sx;
    sum += amplitude * (top * (1 - sy) + bottom * sy);
    weight += amplitude;
  }
  return sum / weight;
}

std::uint8_t layer_pixel(const Layer& layer, int x, int y) {
  const double v = layer.brightness + 1.7 * (value_noise(x, y, layer.seed) - 0.5);
  return static_cast<std::uint8_t>(std::clamp(std::lround(v * 255.0), 0L, 255L));
}

// The front-most layer that shows at left-image pixel (x, y).
const Layer& front_layer_at(int x, int y) {
  for (auto it = std::rbegin(kLayers); it != std::rend(kLayers); ++it)
    if (it->covers(x, y)) return *it;
  return kLayers[0];
}

}  // namespace

SyntheticStereoPair make_synthetic_stereo_pair() {
  SyntheticStereoPair pair;
  pair.left = Image(kWidth, kHeight);
  pair.right = Image(kWidth, kHeight);
  pair.disparity_px.resize(static_cast<std::size_t>(kWidth) * kHeight);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const Layer& seen_left = front_layer_at(x, y);
      pair.left.at(x, y) = layer_pixel(seen_left, x, y);
      pair.disparity_px[static_cast<std::size_t>(y) * kWidth + x] = static_cast<std::uint8_t>(seen_left.disparity_px);
      // Right pixel x sees, of each plane, the point the left image has at x + d; the front-most
      // plane that is there wins. The background extends past the left image's border.
      const Layer* seen_right = &kLayers[0];
      for (auto it = std::rbegin(kLayers); it != std::rend(kLayers); ++it)
        if (it->covers(x + it->disparity_px, y)) {
          seen_right = &*it;
          break;
        }
      pair.right.at(x, y) = layer_pixel(*seen_right, x + seen_right->disparity_px, y);
    }
  }
  pair.min_disparity_px = kLayers[0].disparity_px;
  pair.max_disparity_px = kLayers[0].disparity_px;
  for (const auto& layer : kLayers) {
    pair.min_disparity_px = std::min(pair.min_disparity_px, layer.disparity_px);
    pair.max_disparity_px = std::max(pair.max_disparity_px, layer.disparity_px);
  }
  pair.description = "built-in synthetic stereo pair: " + std::to_string(kWidth) + "x" + std::to_string(kHeight) +
                     ", a textured background and 5 textured rectangles at known disparities " +
                     std::to_string(pair.min_disparity_px) + ".." + std::to_string(pair.max_disparity_px) + " px";
  return pair;
}

}  // namespace porta::app
