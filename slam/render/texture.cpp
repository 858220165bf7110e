// Procedural textures (texture.hpp). Every generator works on a torus (coordinates wrap at `size`),
// so textures tile without seams; all randomness comes from hash_of(seed, ...).
#include "porta/slam/render/texture.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "porta/slam/render/hash.hpp"

namespace porta::slam::render {

namespace {

double quintic(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

// Value noise with `period` lattice cells across the texture (wraps at the texture's size), in [-1, 1].
double value_noise(double x, double y, int size, int period, std::uint64_t seed) {
  const double cell = static_cast<double>(size) / period;
  const double fx = x / cell, fy = y / cell;
  const int ix = static_cast<int>(std::floor(fx)), iy = static_cast<int>(std::floor(fy));
  const double tx = quintic(fx - ix), ty = quintic(fy - iy);
  auto lattice = [&](int i, int j) {
    const int wi = ((i % period) + period) % period, wj = ((j % period) + period) % period;
    return unit_of(hash_of(seed, wi, wj, period)) * 2.0 - 1.0;
  };
  const double a = lattice(ix, iy), b = lattice(ix + 1, iy), c = lattice(ix, iy + 1), d = lattice(ix + 1, iy + 1);
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

// Sum of octaves from `base_period` cells up, amplitude times `gain` per octave (gain 0.5 ~ 1/f).
double fbm(double x, double y, int size, int base_period, int octaves, double gain, std::uint64_t seed) {
  double sum = 0.0, amplitude = 1.0;
  int period = base_period;
  for (int o = 0; o < octaves && period <= size; ++o) {
    sum += amplitude * value_noise(x, y, size, period, seed + static_cast<std::uint64_t>(o) * 7919u);
    amplitude *= gain;
    period *= 2;
  }
  return sum;
}

struct Canvas {
  int size;
  std::vector<double> v;
  explicit Canvas(int n) : size(n), v(static_cast<std::size_t>(n) * n, 0.0) {}
  double& at(int x, int y) {
    const int m = size - 1;
    return v[static_cast<std::size_t>(y & m) * size + (x & m)];
  }
};

// add_fbm() with the lattice of each octave tabulated first (the same values value_noise() hashes).
void add_fbm(Canvas& c, double amplitude, int base_period, int octaves, double gain, std::uint64_t seed,
             double stretch_x = 1.0) {
  if (stretch_x != 1.0) {
    for (int y = 0; y < c.size; ++y)
      for (int x = 0; x < c.size; ++x)
        c.at(x, y) += amplitude * fbm(x * stretch_x, y, c.size, base_period, octaves, gain, seed);
    return;
  }
  double a = amplitude;
  int period = base_period;
  std::vector<double> lattice;
  for (int o = 0; o < octaves && period <= c.size; ++o, a *= gain, period *= 2) {
    const std::uint64_t octave_seed = seed + static_cast<std::uint64_t>(o) * 7919u;
    lattice.resize(static_cast<std::size_t>(period) * period);
    for (int j = 0; j < period; ++j)
      for (int i = 0; i < period; ++i)
        lattice[static_cast<std::size_t>(j) * period + i] = unit_of(hash_of(octave_seed, i, j, period)) * 2.0 - 1.0;
    const double cell = static_cast<double>(c.size) / period;
    for (int y = 0; y < c.size; ++y) {
      const double fy = y / cell;
      const int iy = static_cast<int>(fy);
      const double ty = quintic(fy - iy);
      const double* r0 = lattice.data() + static_cast<std::size_t>(iy % period) * period;
      const double* r1 = lattice.data() + static_cast<std::size_t>((iy + 1) % period) * period;
      for (int x = 0; x < c.size; ++x) {
        const double fx = x / cell;
        const int ix = static_cast<int>(fx), ix1 = (ix + 1) % period;
        const double tx = quintic(fx - ix);
        const double top = r0[ix % period] + (r0[ix1] - r0[ix % period]) * tx;
        const double bottom = r1[ix % period] + (r1[ix1] - r1[ix % period]) * tx;
        c.at(x, y) += a * (top + (bottom - top) * ty);
      }
    }
  }
}

// Soft-edged ellipses of random size, orientation and sign (stains, patches, clumps).
void add_blobs(Canvas& c, int count, double min_r, double max_r, double amplitude, std::uint64_t seed) {
  HashRng rng(seed);
  for (int k = 0; k < count; ++k) {
    const double cx = rng.uniform(0, c.size), cy = rng.uniform(0, c.size);
    const double r1 = rng.uniform(min_r, max_r), r2 = r1 * rng.uniform(0.4, 1.0);
    const double angle = rng.uniform(0, 3.14159265), ca = std::cos(angle), sa = std::sin(angle);
    const double value = amplitude * rng.uniform(-1.0, 1.0);
    const int reach = static_cast<int>(std::ceil(r1)) + 1;
    for (int dy = -reach; dy <= reach; ++dy)
      for (int dx = -reach; dx <= reach; ++dx) {
        const double px = std::floor(cx) + dx - cx, py = std::floor(cy) + dy - cy;
        const double a = (px * ca + py * sa) / r1, b = (-px * sa + py * ca) / r2;
        const double d = std::sqrt(a * a + b * b);
        if (d >= 1.0) continue;
        const double edge = std::min(1.0, (1.0 - d) * r2 * 0.7);  // about 1.5 texels of soft edge
        c.at(static_cast<int>(std::floor(cx)) + dx, static_cast<int>(std::floor(cy)) + dy) += value * edge;
      }
  }
}

// Random-walk cracks / scratches, `width` texels wide.
void add_cracks(Canvas& c, int count, int length, double amplitude, double width, std::uint64_t seed) {
  HashRng rng(seed);
  for (int k = 0; k < count; ++k) {
    double x = rng.uniform(0, c.size), y = rng.uniform(0, c.size), heading = rng.uniform(0, 6.2831853);
    for (int s = 0; s < length; ++s) {
      heading += rng.uniform(-0.35, 0.35);
      x += std::cos(heading);
      y += std::sin(heading);
      const int r = static_cast<int>(std::ceil(width));
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          const int ix = static_cast<int>(std::floor(x)) + dx, iy = static_cast<int>(std::floor(y)) + dy;
          const double d = std::hypot(ix + 0.5 - x, iy + 0.5 - y);
          if (d < width) c.at(ix, iy) -= amplitude * (1.0 - d / width);
        }
    }
  }
}

// Small dots (gravel, speckles), 1-3 texels.
void add_speckles(Canvas& c, int count, double amplitude, std::uint64_t seed) {
  HashRng rng(seed);
  for (int k = 0; k < count; ++k) {
    const int x = rng.below(c.size), y = rng.below(c.size), r = 1 + rng.below(2);
    const double value = amplitude * rng.uniform(-1.0, 1.0);
    for (int dy = 0; dy < r; ++dy)
      for (int dx = 0; dx < r; ++dx) c.at(x + dx, y + dy) += value;
  }
}

// Rectangles, outlines, discs and stripes at many scales (posters, shelves, signs).
void add_patterns(Canvas& c, int count, double amplitude, std::uint64_t seed) {
  HashRng rng(seed);
  for (int k = 0; k < count; ++k) {
    const int kind = rng.below(4);
    const double scale = std::pow(2.0, rng.uniform(2.0, std::log2(c.size / 4.0)));
    const int x0 = rng.below(c.size), y0 = rng.below(c.size);
    const int w = std::max(2, static_cast<int>(scale * rng.uniform(0.5, 1.5)));
    const int h = std::max(2, static_cast<int>(scale * rng.uniform(0.5, 1.5)));
    const double value = amplitude * rng.uniform(-1.0, 1.0);
    const int line = std::max(1, w / 10);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        bool on = false;
        switch (kind) {
          case 0: on = true; break;                                                     // filled
          case 1: on = x < line || y < line || x >= w - line || y >= h - line; break;   // outline
          case 2: {                                                                     // disc
            const double a = (x + 0.5) / w * 2 - 1, b = (y + 0.5) / h * 2 - 1;
            on = a * a + b * b < 1.0;
            break;
          }
          default: on = ((x / std::max(1, line * 2)) % 2) == 0; break;                 // stripes
        }
        if (on) c.at(x0 + x, y0 + y) += value;
      }
  }
}

// Maps the canvas to mean `mean`, standard deviation `spread` (grey levels), clamped to [0, 255].
std::vector<float> normalise(const Canvas& c, double mean, double spread) {
  double sum = 0, sum2 = 0;
  for (double v : c.v) sum += v, sum2 += v * v;
  const double n = static_cast<double>(c.v.size());
  const double m = sum / n, sd = std::sqrt(std::max(1e-12, sum2 / n - m * m));
  std::vector<float> out(c.v.size());
  for (std::size_t i = 0; i < c.v.size(); ++i)
    out[i] = static_cast<float>(std::clamp(mean + (c.v[i] - m) / sd * spread, 0.0, 255.0));
  return out;
}

}  // namespace

std::vector<float> generate_texture(Material material, int size, std::uint64_t seed) {
  if (size < 16 || (size & (size - 1)) != 0) throw std::invalid_argument("texture size must be a power of two >= 16");
  const std::uint64_t s = hash_of(seed, 0x7E7, static_cast<int>(material));
  const double k = size / 512.0;  // feature sizes below are for 512-texel textures
  Canvas c(size);
  switch (material) {
    case Material::asphalt:
      add_fbm(c, 1.0, 8, 7, 0.62, s);
      add_speckles(c, static_cast<int>(9000 * k * k), 2.2, s + 1);
      add_blobs(c, static_cast<int>(40 * k * k), 6 * k, 40 * k, 1.2, s + 2);
      add_cracks(c, static_cast<int>(10 * k), static_cast<int>(120 * k), 1.6, 1.3, s + 3);
      return normalise(c, 105, 30);
    case Material::paving: {
      add_fbm(c, 0.6, 16, 6, 0.6, s);
      add_speckles(c, static_cast<int>(4000 * k * k), 1.2, s + 1);
      const int slab = std::max(8, size / 8);
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          const int row = y / slab, shift = (row % 2) * slab / 2, col = (x + shift) / slab;
          c.at(x, y) += 0.8 * (unit_of(hash_of(s, col % 8, row)) - 0.5);
          const int gx = (x + shift) % slab, gy = y % slab;
          if (gx < 2 || gy < 2) c.at(x, y) -= 1.8;
        }
      add_blobs(c, static_cast<int>(25 * k * k), 5 * k, 25 * k, 0.8, s + 2);
      return normalise(c, 140, 32);
    }
    case Material::brick: {
      add_fbm(c, 0.5, 32, 5, 0.6, s);
      const int bh = std::max(4, size / 64), bw = bh * 4;
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          const int row = y / bh, shift = (row % 2) * bw / 2, col = (x + shift) / bw;
          c.at(x, y) += 1.3 * (unit_of(hash_of(s, col % (size / bw), row)) - 0.5);
          if ((x + shift) % bw < 2 || y % bh < 1) c.at(x, y) += 1.6;  // mortar
        }
      add_blobs(c, static_cast<int>(20 * k * k), 10 * k, 50 * k, 0.7, s + 2);
      return normalise(c, 115, 34);
    }
    case Material::plaster:
      add_fbm(c, 1.0, 4, 8, 0.55, s);
      add_blobs(c, static_cast<int>(60 * k * k), 4 * k, 45 * k, 1.2, s + 1);
      add_cracks(c, static_cast<int>(6 * k), static_cast<int>(90 * k), 1.4, 1.0, s + 2);
      add_speckles(c, static_cast<int>(2000 * k * k), 1.0, s + 3);
      return normalise(c, 150, 30);
    case Material::grass:
      add_fbm(c, 1.0, 16, 6, 0.75, s);
      add_speckles(c, static_cast<int>(20000 * k * k), 1.6, s + 1);
      add_blobs(c, static_cast<int>(80 * k * k), 4 * k, 30 * k, 1.4, s + 2);
      return normalise(c, 95, 30);
    case Material::wood: {
      const int plank = std::max(8, size / 8);
      for (int y = 0; y < size; ++y) {
        const int row = y / plank;
        const int end = static_cast<int>(unit_of(hash_of(s, row, 1)) * size);
        for (int x = 0; x < size; ++x) {
          const int piece = ((x - end + size) % size) < size / 2 ? 0 : 1;
          c.at(x, y) += 0.9 * (unit_of(hash_of(s, row, piece, 2)) - 0.5);
          c.at(x, y) += 0.6 * fbm(x * 0.125, y * 2.0, size, 8, 4, 0.6, s + static_cast<std::uint64_t>(row));
          if (y % plank < 2 || ((x - end + size) % (size / 2)) < 2) c.at(x, y) -= 2.0;
        }
      }
      add_fbm(c, 0.4, 32, 4, 0.5, s + 9);
      add_speckles(c, static_cast<int>(600 * k * k), 1.5, s + 3);
      return normalise(c, 120, 32);
    }
    case Material::concrete: {
      add_fbm(c, 1.0, 8, 7, 0.55, s);
      add_blobs(c, static_cast<int>(50 * k * k), 5 * k, 35 * k, 1.0, s + 1);
      const int panel = size / 4;
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          if (x % panel < 2 || y % panel < 2) c.at(x, y) -= 2.0;
          const int hx = (x + panel / 4) % (panel / 2), hy = (y + panel / 4) % (panel / 2);
          if (std::hypot(hx - panel / 4.0, hy - panel / 4.0) < 3 * k + 1) c.at(x, y) -= 2.5;  // form-tie holes
        }
      add_cracks(c, static_cast<int>(8 * k), static_cast<int>(80 * k), 1.5, 1.0, s + 2);
      return normalise(c, 135, 30);
    }
    case Material::patterned:
      add_fbm(c, 0.8, 8, 6, 0.6, s);
      add_patterns(c, static_cast<int>(500 * k * k), 2.0, s + 1);
      add_speckles(c, static_cast<int>(3000 * k * k), 0.8, s + 2);
      return normalise(c, 128, 45);
    case Material::clouds: {
      Canvas wisps(size);
      add_fbm(c, 1.0, 4, 7, 0.6, s);
      add_fbm(wisps, 1.0, 32, 4, 0.7, s + 5);
      for (std::size_t i = 0; i < c.v.size(); ++i)  // cloud patches on a hazy sky
        c.v[i] = 0.4 * c.v[i] + std::max(0.0, c.v[i] - 0.1) * 1.4 + 0.25 * wisps.v[i];
      return normalise(c, 185, 28);
    }
    case Material::count: break;
  }
  throw std::invalid_argument("unknown material");
}

MipTexture::MipTexture(int size, const std::vector<float>& level0) : size_(size) {
  if (size < 2 || (size & (size - 1)) != 0 || level0.size() != static_cast<std::size_t>(size) * size)
    throw std::invalid_argument("MipTexture: size must be a power of two matching the data");
  while ((1 << log2_size_) < size) ++log2_size_;
  std::vector<float> current = level0;
  int n = size;
  for (;;) {
    std::vector<std::uint8_t> bytes(current.size());
    for (std::size_t i = 0; i < current.size(); ++i)
      bytes[i] = static_cast<std::uint8_t>(std::lround(std::clamp(current[i], 0.0f, 255.0f)));
    levels_.push_back(std::move(bytes));
    if (n == 1) break;
    const int h = n / 2;
    std::vector<float> next(static_cast<std::size_t>(h) * h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < h; ++x) {
        const std::size_t a = static_cast<std::size_t>(2 * y) * n + 2 * x;
        next[static_cast<std::size_t>(y) * h + x] = 0.25f * (current[a] + current[a + 1] + current[a + n] + current[a + n + 1]);
      }
    current = std::move(next);
    n = h;
  }
}

TextureBank::TextureBank(std::uint64_t seed, int size, int threads) : size_(size) {
  if (size < 16 || size > 4096 || (size & (size - 1)) != 0)
    throw std::invalid_argument("texture size must be a power of two in [16, 4096]");
  threads = std::clamp(threads, 1, kMaterialCount);
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t)
    workers.emplace_back([&, t] {
      for (int m = t; m < kMaterialCount; m += threads)
        textures_[m] = MipTexture(size, generate_texture(static_cast<Material>(m), size, seed));
    });
  for (auto& w : workers) w.join();
}

}  // namespace porta::slam::render
