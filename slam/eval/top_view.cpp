// The run's top view (top_view.hpp): fit, then draw the map points, the trajectories, the caption,
// the legend and the scale bar into an RGB buffer.
#include "porta/slam/top_view.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string_view>

#include "pixel_font.hpp"

namespace porta::slam {

namespace {

constexpr int kFontScale = 2;                                            // 10 x 14 px glyphs
constexpr int kLineHeight = (pixel_font::kCellHeight + 2) * kFontScale;  // 22 px
constexpr int kMargin = 16;
constexpr int kMinWidth = 1040;  // room for the caption and the legend
constexpr int kHeaderHeight = kMargin + 3 * kLineHeight + 6;
constexpr int kFooterHeight = 44;  // the scale bar and its label
constexpr double kMarginFraction = 0.04;

using Colour = std::array<std::uint8_t, 3>;
constexpr Colour kWhite = {255, 255, 255};
constexpr Colour kText = {30, 30, 30};
constexpr Colour kFrame = {200, 200, 200};
constexpr Colour kPointSwatch = {110, 110, 110};

Colour colour_of(const std::uint8_t (&c)[3]) { return {c[0], c[1], c[2]}; }

class Canvas {
 public:
  explicit Canvas(RgbImage& image) : image_(image) {}

  void put(int x, int y, const Colour& c) {
    if (x < 0 || y < 0 || x >= image_.width || y >= image_.height) return;
    std::uint8_t* p = &image_.rgb[(static_cast<std::size_t>(y) * image_.width + x) * 3];
    p[0] = c[0];
    p[1] = c[1];
    p[2] = c[2];
  }

  void fill_rect(int x, int y, int w, int h, const Colour& c) {
    for (int yy = y; yy < y + h; ++yy)
      for (int xx = x; xx < x + w; ++xx) put(xx, yy, c);
  }

  /// Mixes `c` into the pixel by `alpha` in [0, 1].
  void blend(int x, int y, const Colour& c, double alpha) {
    if (x < 0 || y < 0 || x >= image_.width || y >= image_.height || alpha <= 0.0) return;
    std::uint8_t* p = &image_.rgb[(static_cast<std::size_t>(y) * image_.width + x) * 3];
    for (int k = 0; k < 3; ++k)
      p[k] = static_cast<std::uint8_t>(
          std::lround(p[k] + std::min(alpha, 1.0) * (c[static_cast<std::size_t>(k)] - p[k])));
  }

  /// A filled, anti-aliased disc.
  void disc(double cx, double cy, double radius, const Colour& c) { line(cx, cy, cx, cy, radius, c); }

  /// A thick anti-aliased segment with round ends: every pixel within `radius` of it takes the
  /// colour, with a one-pixel soft edge.
  void line(double xa, double ya, double xb, double yb, double radius, const Colour& c) {
    const int x_lo = static_cast<int>(std::floor(std::min(xa, xb) - radius - 1.0));
    const int x_hi = static_cast<int>(std::ceil(std::max(xa, xb) + radius + 1.0));
    const int y_lo = static_cast<int>(std::floor(std::min(ya, yb) - radius - 1.0));
    const int y_hi = static_cast<int>(std::ceil(std::max(ya, yb) + radius + 1.0));
    const double dx = xb - xa, dy = yb - ya, length2 = dx * dx + dy * dy;
    for (int y = std::max(0, y_lo); y <= std::min(image_.height - 1, y_hi); ++y)
      for (int x = std::max(0, x_lo); x <= std::min(image_.width - 1, x_hi); ++x) {
        const double t =
            length2 > 0.0 ? std::clamp(((x - xa) * dx + (y - ya) * dy) / length2, 0.0, 1.0) : 0.0;
        const double distance = std::hypot(x - (xa + t * dx), y - (ya + t * dy));
        blend(x, y, c, radius + 0.5 - distance);
      }
  }

  /// Text with its top-left corner at (x, y); returns the x after it.
  int text(int x, int y, std::string_view s, const Colour& c) {
    for (const char ch : s) {
      const auto& columns = pixel_font::glyph(ch);
      for (int col = 0; col < pixel_font::kGlyphWidth; ++col)
        for (int row = 0; row < pixel_font::kCellHeight; ++row)
          if ((columns[static_cast<std::size_t>(col)] >> row) & 1)
            fill_rect(x + col * kFontScale, y + row * kFontScale, kFontScale, kFontScale, c);
      x += pixel_font::kAdvance * kFontScale;
    }
    return x;
  }

 private:
  RgbImage& image_;
};

/// `s` cut from the left ("...tail") to fit `width_px`.
std::string fit_text(const std::string& s, int width_px) {
  const int max_chars = std::max(4, (width_px + kFontScale) / (pixel_font::kAdvance * kFontScale));
  if (static_cast<int>(s.size()) <= max_chars) return s;
  return "..." + s.substr(s.size() - static_cast<std::size_t>(max_chars - 3));
}

/// The value at fraction f of the sorted values (by rank, as map_export's height_range).
double percentile(std::vector<double> values, double f) {
  const auto k = static_cast<std::size_t>(std::lround(f * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

bool finite_xz(const Eigen::Vector3d& p) { return std::isfinite(p.x()) && std::isfinite(p.z()); }

struct Bounds {
  double min_x = std::numeric_limits<double>::infinity(), max_x = -std::numeric_limits<double>::infinity();
  double min_z = std::numeric_limits<double>::infinity(), max_z = -std::numeric_limits<double>::infinity();
  bool empty() const { return !(min_x <= max_x); }
  void add(double x, double z) {
    min_x = std::min(min_x, x);
    max_x = std::max(max_x, x);
    min_z = std::min(min_z, z);
    max_z = std::max(max_z, z);
  }
};

Bounds fit_bounds(const TopViewInput& input) {
  Bounds b;
  for (const auto* path : {&input.estimate, &input.ground_truth})
    for (const Eigen::Vector3d& p : *path)
      if (finite_xz(p)) b.add(p.x(), p.z());
  std::vector<double> xs, zs;
  for (const Eigen::Vector3d& p : input.map_points) {
    if (!finite_xz(p)) continue;
    xs.push_back(p.x());
    zs.push_back(p.z());
  }
  if (!xs.empty()) {
    b.add(percentile(xs, 0.01), percentile(zs, 0.01));
    b.add(percentile(xs, 0.99), percentile(zs, 0.99));
  }
  if (b.empty()) b.add(0.0, 0.0);
  return b;
}

/// 1, 2 or 5 times a power of ten, at most `limit`.
double nice_length(double limit) {
  const double power = std::pow(10.0, std::floor(std::log10(limit)));
  for (const double m : {5.0, 2.0, 1.0})
    if (m * power <= limit) return m * power;
  return power;
}

std::string format_length(double metres) {
  char text[32];
  if (metres >= 1.0) {
    std::snprintf(text, sizeof text, "%.0f m", metres);
  } else {
    std::snprintf(text, sizeof text, "%.0f cm", metres * 100.0);
  }
  return text;
}

}  // namespace

RgbImage draw_top_view(const TopViewInput& input, int plot_side_px, TopViewFrame* frame_out) {
  plot_side_px = std::max(plot_side_px, 200);
  // The world rectangle: the content's bounds, the shorter side at least a quarter of the longer
  // (a straight drive stays readable) and 1 m, then margins.
  const Bounds b = fit_bounds(input);
  double extent_x = b.max_x - b.min_x, extent_z = b.max_z - b.min_z;
  const double longer = std::max({extent_x, extent_z, 1.0});
  extent_x = std::max(extent_x, 0.25 * longer);
  extent_z = std::max(extent_z, 0.25 * longer);
  const double centre_x = 0.5 * (b.min_x + b.max_x), centre_z = 0.5 * (b.min_z + b.max_z);
  extent_x *= 1.0 + 2.0 * kMarginFraction;
  extent_z *= 1.0 + 2.0 * kMarginFraction;

  TopViewFrame frame;
  frame.pixels_per_m = plot_side_px / std::max(extent_x, extent_z);
  frame.plot_width = std::max(1, static_cast<int>(std::lround(extent_x * frame.pixels_per_m)));
  frame.plot_height = std::max(1, static_cast<int>(std::lround(extent_z * frame.pixels_per_m)));
  frame.min_x = centre_x - 0.5 * extent_x;
  frame.max_z = centre_z + 0.5 * extent_z;

  RgbImage image;
  image.width = std::max(kMinWidth, frame.plot_width + 2 * kMargin);
  image.height = kHeaderHeight + frame.plot_height + kFooterHeight;
  image.rgb.assign(static_cast<std::size_t>(image.width) * image.height * 3, 255);
  frame.x0 = (image.width - frame.plot_width) / 2;
  frame.y0 = kHeaderHeight;
  if (frame_out != nullptr) *frame_out = frame;
  Canvas canvas(image);

  // Map points: grey, darker where more fall on one pixel (x 0.8 per point), so that dense structure shows.
  std::vector<std::uint16_t> counts(static_cast<std::size_t>(frame.plot_width) * frame.plot_height, 0);
  for (const Eigen::Vector3d& p : input.map_points) {
    if (!finite_xz(p)) continue;
    const double col = std::floor(frame.column(p.x()) - frame.x0),
                 row = std::floor(frame.row(p.z()) - frame.y0);
    if (col < 0 || row < 0 || col >= frame.plot_width || row >= frame.plot_height) continue;
    std::uint16_t& n =
        counts[static_cast<std::size_t>(row) * frame.plot_width + static_cast<std::size_t>(col)];
    if (n < 64) ++n;
  }
  for (int row = 0; row < frame.plot_height; ++row)
    for (int col = 0; col < frame.plot_width; ++col) {
      const int n = counts[static_cast<std::size_t>(row) * frame.plot_width + col];
      if (n == 0) continue;
      const auto v = static_cast<std::uint8_t>(std::lround(std::max(20.0, 130.0 * std::pow(0.8, n - 1))));
      canvas.put(frame.x0 + col, frame.y0 + row, {v, v, v});
    }

  // The plot's frame.
  canvas.fill_rect(frame.x0 - 1, frame.y0 - 1, frame.plot_width + 2, 1, kFrame);
  canvas.fill_rect(frame.x0 - 1, frame.y0 + frame.plot_height, frame.plot_width + 2, 1, kFrame);
  canvas.fill_rect(frame.x0 - 1, frame.y0 - 1, 1, frame.plot_height + 2, kFrame);
  canvas.fill_rect(frame.x0 + frame.plot_width, frame.y0 - 1, 1, frame.plot_height + 2, kFrame);

  // Trajectories: the ground truth wider and under the estimate, so both show where they agree.
  const auto path = [&](const std::vector<Eigen::Vector3d>& positions, double radius, const Colour& c) {
    for (std::size_t k = 1; k < positions.size(); ++k) {
      const Eigen::Vector3d &a = positions[k - 1], &p = positions[k];
      if (!finite_xz(a) || !finite_xz(p)) continue;
      canvas.line(frame.column(a.x()), frame.row(a.z()), frame.column(p.x()), frame.row(p.z()), radius, c);
    }
  };
  path(input.ground_truth, 3.0, colour_of(top_view_colours::kGroundTruth));
  path(input.estimate, 1.5, colour_of(top_view_colours::kEstimate));
  if (!input.estimate.empty()) {
    const Eigen::Vector3d &first = input.estimate.front(), &last = input.estimate.back();
    if (finite_xz(last))
      canvas.disc(frame.column(last.x()), frame.row(last.z()), 5.0, colour_of(top_view_colours::kEnd));
    if (finite_xz(first)) {
      canvas.disc(frame.column(first.x()), frame.row(first.z()), 7.0, kWhite);
      canvas.disc(frame.column(first.x()), frame.row(first.z()), 6.0, colour_of(top_view_colours::kStart));
    }
  }

  // Caption: the title, what the view is, and the legend.
  const int text_room = image.width - 2 * kMargin;
  int y = kMargin;
  canvas.text(kMargin, y, fit_text(input.title, text_room), kText);
  y += kLineHeight;
  char counts_text[160];
  std::snprintf(counts_text, sizeof counts_text,
                "top view: x right, z (forward) up; %zu map points, %zu poses", input.map_points.size(),
                input.estimate.size());
  canvas.text(kMargin, y, fit_text(counts_text, text_room), kText);
  y += kLineHeight;
  const int swatch_y = y + pixel_font::kGlyphHeight * kFontScale / 2;
  int x = kMargin;
  for (int k = 0; k < 3; ++k)
    canvas.fill_rect(x + 2 + 8 * k, swatch_y - 1 + (k % 2) * 3 - 1, 3, 3, kPointSwatch);
  x = canvas.text(x + 30, y, "map points", kText) + 24;
  canvas.line(x, swatch_y, x + 28, swatch_y, 1.5, colour_of(top_view_colours::kEstimate));
  x = canvas.text(x + 36, y, "estimate", kText) + 24;
  if (!input.ground_truth.empty()) {
    canvas.line(x, swatch_y, x + 28, swatch_y, 3.0, colour_of(top_view_colours::kGroundTruth));
    x = canvas.text(x + 36, y, input.ground_truth_label, kText) + 24;
  }
  canvas.disc(x + 6, swatch_y, 6.0, colour_of(top_view_colours::kStart));
  x = canvas.text(x + 18, y, "start", kText) + 18;
  canvas.disc(x + 5, swatch_y, 5.0, colour_of(top_view_colours::kEnd));
  canvas.text(x + 16, y, "end", kText);

  // Scale bar under the plot's left end: a round length near a fifth of the plot's width.
  const double bar_m = nice_length(0.2 * frame.plot_width / frame.pixels_per_m);
  const int bar_px = std::max(1, static_cast<int>(std::lround(bar_m * frame.pixels_per_m)));
  const int bar_y = frame.y0 + frame.plot_height + 14;
  canvas.fill_rect(frame.x0, bar_y, bar_px, 3, kText);
  canvas.fill_rect(frame.x0, bar_y - 5, 2, 13, kText);
  canvas.fill_rect(frame.x0 + bar_px - 2, bar_y - 5, 2, 13, kText);
  canvas.text(frame.x0 + bar_px + 10, bar_y - pixel_font::kGlyphHeight * kFontScale / 2 + 1,
              format_length(bar_m), kText);
  return image;
}

}  // namespace porta::slam
