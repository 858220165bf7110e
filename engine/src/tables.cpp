#include "porta/tables.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace porta {

// Clockwise from 12 o'clock (y grows downwards).
const std::array<std::pair<int, int>, 16> kFastCircle = {{{0, -3}, {1, -3}, {2, -2}, {3, -1},
                                                          {3, 0},  {3, 1},  {2, 2},  {1, 3},
                                                          {0, 3},  {-1, 3}, {-2, 2}, {-3, 1},
                                                          {-3, 0}, {-3, -1}, {-2, -2}, {-1, -3}}};

int longest_circular_run(std::uint16_t mask) {
  if (mask == 0xFFFF) return 16;
  // Walking 32 bits (the mask twice) sees every circular run whole.
  const std::uint32_t twice = static_cast<std::uint32_t>(mask) | (static_cast<std::uint32_t>(mask) << 16);
  int best = 0, run = 0;
  for (int i = 0; i < 32; ++i) {
    run = ((twice >> i) & 1u) ? run + 1 : 0;
    best = std::max(best, run);
  }
  return std::min(best, 16);
}

std::vector<std::uint8_t> build_fast_lut(int min_arc, int max_arc) {
  std::vector<std::uint8_t> lut(1 << 16);
  for (std::uint32_t m = 0; m < lut.size(); ++m) {
    const int run = longest_circular_run(static_cast<std::uint16_t>(m));
    lut[m] = (run >= min_arc && run <= max_arc) ? 1 : 0;
  }
  return lut;
}

std::vector<std::pair<int, int>> pyramid_level_sizes(int width, int height, int levels, double scale) {
  std::vector<std::pair<int, int>> sizes;
  for (int n = 0; n < levels; ++n) {
    const double f = std::pow(scale, n);
    sizes.emplace_back(std::max(1L, std::lround(width / f)), std::max(1L, std::lround(height / f)));
  }
  return sizes;
}

namespace {

ResizeAxis build_axis(int src_size, int dst_size) {
  ResizeAxis axis;
  const double ratio = static_cast<double>(src_size) / dst_size;
  for (int j = 0; j < dst_size; ++j) {
    double s = (j + 0.5) * ratio - 0.5;
    s = std::clamp(s, 0.0, static_cast<double>(src_size - 1));
    const double s0 = std::floor(s);
    axis.src0.push_back(static_cast<std::int32_t>(s0));
    axis.w1.push_back(static_cast<std::int32_t>(std::lround((s - s0) * 2048.0)));
  }
  return axis;
}

}  // namespace

ResizeTables build_resize_tables(const std::vector<std::pair<int, int>>& level_sizes) {
  ResizeTables t;
  for (std::size_t n = 1; n < level_sizes.size(); ++n) {
    const auto [pw, ph] = level_sizes[n - 1];
    const auto [w, h] = level_sizes[n];
    t.cols.push_back(build_axis(pw, w));
    t.rows.push_back(build_axis(ph, h));
    t.level_offset.push_back(static_cast<std::int32_t>(t.packed.size()));
    for (const auto* v : {&t.cols.back().src0, &t.cols.back().w1, &t.rows.back().src0, &t.rows.back().w1})
      t.packed.insert(t.packed.end(), v->begin(), v->end());
  }
  return t;
}

std::vector<std::int32_t> build_level_scales_q16(int levels, double scale) {
  std::vector<std::int32_t> s;
  for (int n = 0; n < levels; ++n) s.push_back(static_cast<std::int32_t>(std::lround(std::pow(scale, n) * 65536.0)));
  return s;
}

CellLayout build_cell_layout(const std::vector<std::pair<int, int>>& level_sizes, int cell_width,
                             int cell_height, double scale) {
  CellLayout layout;
  for (std::size_t n = 0; n < level_sizes.size(); ++n) {
    const double f = std::pow(scale, static_cast<double>(n));
    LevelCells c;
    // The small epsilon keeps an exact quotient (e.g. 32 / 2^n) from flooring one below.
    c.cell_w = std::max(1, static_cast<int>(std::floor(cell_width / f + 1e-9)));
    c.cell_h = std::max(1, static_cast<int>(std::floor(cell_height / f + 1e-9)));
    c.cols = (level_sizes[n].first + c.cell_w - 1) / c.cell_w;
    c.rows = (level_sizes[n].second + c.cell_h - 1) / c.cell_h;
    c.first_cell = layout.total_cells;
    layout.total_cells += c.count();
    layout.levels.push_back(c);
  }
  return layout;
}

std::array<int, kOrientationRadius + 1> build_orientation_umax() {
  std::array<int, kOrientationRadius + 1> umax{};
  for (int dy = 0; dy <= kOrientationRadius; ++dy) {
    int u = 0;
    while ((u + 1) * (u + 1) + dy * dy <= 240) ++u;
    umax[dy] = u;
  }
  return umax;
}

std::vector<std::int32_t> build_orientation_boundaries(int bins) {
  std::vector<std::int32_t> b;
  for (int k = 0; k < bins; ++k) {
    const double phi = 2.0 * std::numbers::pi * (k - 0.5) / bins;
    b.push_back(static_cast<std::int32_t>(std::lround(1024.0 * std::cos(phi))));
    b.push_back(static_cast<std::int32_t>(std::lround(1024.0 * std::sin(phi))));
  }
  return b;
}

double orientation_bin_center_rad(int bin, int bins) { return 2.0 * std::numbers::pi * bin / bins; }

std::array<std::int32_t, 7> build_blur_taps() {
  std::array<double, 7> g{};
  double sum = 0;
  for (int k = -3; k <= 3; ++k) sum += g[k + 3] = std::exp(-(k * k) / (2.0 * 2.0 * 2.0));
  std::array<std::int32_t, 7> taps{};
  int outer = 0;
  for (int k = 0; k < 7; ++k) {
    if (k == 3) continue;
    taps[k] = static_cast<std::int32_t>(std::lround(g[k] / sum * 256.0));
    outer += taps[k];
  }
  taps[3] = 256 - outer;
  return taps;
}

namespace {

// splitmix64: a fixed, portable generator, so the pattern is the same on every machine.
std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// An approximately Gaussian integer offset with sigma 31/5, from the sum of 12 uniform 16-bit
// integers (Irwin-Hall), in integer arithmetic only, clipped to the pattern's extent.
int gaussian_offset(std::uint64_t& state) {
  std::int64_t sum = 0;
  for (int i = 0; i < 12; ++i) sum += static_cast<std::int64_t>(splitmix64(state) & 0xFFFF);
  const std::int64_t centred = sum - 6 * 65536;           // ~ N(0, 1) * 65536
  const std::int64_t scaled = centred * 62;               // * sigma * 10
  const std::int64_t den = 10 * 65536;
  const std::int64_t q = (scaled >= 0 ? scaled + den / 2 : scaled - den / 2) / den;  // round half away
  return static_cast<int>(std::clamp<std::int64_t>(q, -kOrbPatternExtent, kOrbPatternExtent));
}

}  // namespace

const std::array<std::array<std::int8_t, 4>, kOrbPairs>& orb_base_pattern() {
  static const auto pattern = [] {
    std::array<std::array<std::int8_t, 4>, kOrbPairs> p{};
    std::uint64_t state = 0x504F525441534C41ull;  // "PORTASLA"
    for (auto& pair : p) {
      int v[4];
      do {
        for (int& c : v) c = gaussian_offset(state);
      } while (v[0] == v[2] && v[1] == v[3]);  // a point compared with itself carries no bit
      for (int i = 0; i < 4; ++i) pair[i] = static_cast<std::int8_t>(v[i]);
    }
    return p;
  }();
  return pattern;
}

std::vector<std::int8_t> build_orb_pattern_table(int bins) {
  const auto& base = orb_base_pattern();
  std::vector<std::int8_t> table;
  table.reserve(static_cast<std::size_t>(bins) * kOrbPairs * 4);
  // Products that are exact halves in real numbers (x * sin 30deg) can land a hair below .5 in
  // double; nudging away from zero rounds them as the exact value would.
  auto round_half_away = [](double v) { return std::lround(v + (v >= 0 ? 1e-9 : -1e-9)); };
  for (int b = 0; b < bins; ++b) {
    // With B a multiple of 4, rotate by the angle within the quadrant, then by whole quarter turns
    // exactly, so that the table of bin b + B/4 is bin b's turned by 90 degrees to the bit.
    const int quarters = bins % 4 == 0 ? b / (bins / 4) : 0;
    const double a = orientation_bin_center_rad(b - quarters * (bins / 4), bins);
    const double c = std::cos(a), s = std::sin(a);
    for (const auto& pair : base) {
      for (int pt = 0; pt < 2; ++pt) {
        const double x = pair[2 * pt], y = pair[2 * pt + 1];
        long rx = round_half_away(c * x - s * y), ry = round_half_away(s * x + c * y);
        for (int q = 0; q < quarters; ++q) {  // (x, y) -> (-y, x): +90 degrees with y down
          const long t = rx;
          rx = -ry;
          ry = t;
        }
        table.push_back(static_cast<std::int8_t>(rx));
        table.push_back(static_cast<std::int8_t>(ry));
      }
    }
  }
  return table;
}

std::vector<std::int32_t> build_stereo_row_radius_q8(int levels, double scale) {
  std::vector<std::int32_t> r;
  for (int n = 0; n < levels; ++n) r.push_back(static_cast<std::int32_t>(std::lround(2.0 * std::pow(scale, n) * 256.0)));
  return r;
}

FrontendTables FrontendTables::build(const FrontendSettings& settings, int width, int height) {
  settings.validate();
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide)
    throw std::invalid_argument("image size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is outside [1, " + std::to_string(kMaxImageSide) + "] per side");
  FrontendTables t;
  t.settings = settings;
  t.level_sizes = pyramid_level_sizes(width, height, settings.levels, settings.scale_factor);
  t.fast_lut = build_fast_lut(settings.min_arc, settings.max_arc);
  t.resize = build_resize_tables(t.level_sizes);
  t.scales_q16 = build_level_scales_q16(settings.levels, settings.scale_factor);
  t.cells = build_cell_layout(t.level_sizes, settings.cell_width, settings.cell_height, settings.scale_factor);
  t.umax = build_orientation_umax();
  t.orientation_boundaries = build_orientation_boundaries(settings.orientation_bins);
  t.blur_taps = build_blur_taps();
  t.orb_pattern = build_orb_pattern_table(settings.orientation_bins);
  t.stereo_row_radius_q8 = build_stereo_row_radius_q8(settings.levels, settings.scale_factor);
  return t;
}

}  // namespace porta
