#include "annotate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <opencv2/imgproc.hpp>

#include "level_colours.hpp"
#include "porta/tables.hpp"

namespace porta::app {

namespace {

// Sub-pixel drawing: OpenCV takes coordinates with this many fractional bits.
constexpr int kShift = 4;
constexpr double kOne = 1 << kShift;

// Keypoint circle radius at level 0; level n is drawn kBaseRadius * s^n.
constexpr double kBaseRadius = 4.0;

cv::Point fixed_point(double x, double y) {
  return {static_cast<int>(std::lround(x * kOne)), static_cast<int>(std::lround(y * kOne))};
}

cv::Scalar level_colour(int level) {
  const auto& c = kLevelColoursBgr[static_cast<std::size_t>(level) % kLevelColoursBgr.size()];
  return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
}

// Turbo colour map over [lo, hi], without its darkest eighth so that small disparities stay
// visible on the dimmed image.
class DisparityColours {
 public:
  DisparityColours(double lo, double hi) : lo_(lo), hi_(std::max(hi, lo + 1.0)) {
    cv::Mat ramp(1, 256, CV_8U);
    for (int i = 0; i < 256; ++i) ramp.at<std::uint8_t>(0, i) = static_cast<std::uint8_t>(i);
    cv::applyColorMap(ramp, lut_, cv::COLORMAP_TURBO);
  }
  cv::Scalar operator()(double disparity) const {
    const int i = std::clamp(static_cast<int>(std::lround(32.0 + (disparity - lo_) / (hi_ - lo_) * 223.0)), 32, 255);
    const auto c = lut_.at<cv::Vec3b>(0, i);
    return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
  }
  double lo() const { return lo_; }
  double hi() const { return hi_; }

 private:
  double lo_, hi_;
  cv::Mat lut_;
};

cv::Mat to_bgr(const Image& image, double brightness = 1.0) {
  const cv::Mat gray(image.height(), image.width(), CV_8U, const_cast<std::uint8_t*>(image.data()),
                     static_cast<std::size_t>(image.pitch_bytes()));
  cv::Mat scaled, bgr;
  gray.convertTo(scaled, CV_8U, brightness);
  cv::cvtColor(scaled, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

double level_scale(const FrontendTables& tables, int level) { return tables.scales_q16[level] / 65536.0; }

// Tiny inputs still get a readable legend: panels are at least this large (the image sits at the
// top left of its panel).
constexpr int kMinPanelWidth = 360;
constexpr int kMinPanelHeight = 270;

// Text sized to the image so that it stays readable on 384 px and 1226 px wide inputs alike.
double font_scale_for(int width) { return std::clamp(width / 900.0, 0.38, 0.8); }

void label(cv::Mat& canvas, const std::string& text, cv::Point origin, double font_scale,
           cv::Scalar colour = {255, 255, 255}) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, font_scale, 1, &baseline);
  cv::rectangle(canvas, origin + cv::Point(-3, -size.height - 4), origin + cv::Point(size.width + 3, baseline + 2),
                {0, 0, 0}, cv::FILLED);
  cv::putText(canvas, text, origin, cv::FONT_HERSHEY_SIMPLEX, font_scale, colour, 1, cv::LINE_AA);
}

void draw_keypoints(cv::Mat& canvas, const Features& features, const FrontendTables& tables) {
  const int bins = tables.settings.orientation_bins;
  for (std::size_t i = 0; i < features.keypoints.size(); ++i) {
    const Keypoint& k = features.keypoints[i];
    const double x = features.level0_x(i, tables), y = features.level0_y(i, tables);
    const double radius = kBaseRadius * level_scale(tables, k.level);
    const cv::Scalar colour = level_colour(k.level);
    cv::circle(canvas, fixed_point(x, y), static_cast<int>(std::lround(radius * kOne)), colour, 1, cv::LINE_AA,
               kShift);
    if (!features.descriptors.empty()) {  // orientation is only computed when describing
      // Image rows grow downwards, as do the centroid's y moments, so the angle maps directly.
      const double angle = orientation_bin_center_rad(k.angle_bin, bins);
      cv::line(canvas, fixed_point(x, y), fixed_point(x + radius * std::cos(angle), y + radius * std::sin(angle)),
               colour, 1, cv::LINE_AA, kShift);
    }
  }
}

// The level legend: one "Ln xS" entry per level, a filled swatch then the text, laid out in rows
// that wrap at a width. Laid out once, then measured or drawn.
struct LegendEntry {
  cv::Point origin;  // text baseline start of the swatch
  std::string text;
  int swatch;  // swatch diameter
};

std::vector<LegendEntry> layout_level_legend(const FrontendTables& tables, cv::Point origin, int max_x,
                                             double font_scale, int line_height) {
  std::vector<LegendEntry> entries;
  cv::Point at = origin;
  for (int level = 0; level < tables.settings.levels; ++level) {
    char text[32];
    std::snprintf(text, sizeof text, "L%d x%.2f", level, level_scale(tables, level));
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, font_scale, 1, &baseline);
    const int entry_width = size.height + 6 + size.width + 12;
    if (at.x + entry_width > max_x && at.x > origin.x) at = {origin.x, at.y + line_height};
    entries.push_back({at, text, size.height});
    at.x += entry_width;
  }
  return entries;
}

void draw_level_legend(cv::Mat& canvas, const std::vector<LegendEntry>& entries, double font_scale) {
  for (std::size_t level = 0; level < entries.size(); ++level) {
    const LegendEntry& e = entries[level];
    cv::circle(canvas, e.origin + cv::Point(e.swatch / 2, -e.swatch / 2), e.swatch / 2 + 1,
               level_colour(static_cast<int>(level)), cv::FILLED, cv::LINE_AA);
    cv::putText(canvas, e.text, e.origin + cv::Point(e.swatch + 6, 0), cv::FONT_HERSHEY_SIMPLEX, font_scale,
                {230, 230, 230}, 1, cv::LINE_AA);
  }
}

// The largest font scale, at most `font_scale`, at which every line fits in `max_width` pixels.
double fit_font(const std::vector<std::string>& lines, int max_width, double font_scale) {
  for (const auto& line : lines) {
    int baseline = 0;
    const int width = cv::getTextSize(line, cv::FONT_HERSHEY_SIMPLEX, font_scale, 1, &baseline).width;
    if (width > max_width) font_scale *= static_cast<double>(max_width) / width;
  }
  return font_scale;
}

int line_height_for(double font_scale) { return static_cast<int>(std::lround(44.0 * font_scale)); }

// The disparity range the colours span: the 2nd to 98th percentile of the matches, so that a few
// wrong far matches do not squeeze every correct one into one colour.
std::pair<double, double> disparity_colour_range(const StereoFeatures& stereo) {
  std::vector<double> d;
  for (const auto& m : stereo.matches)
    if (m.disparity_q8 >= 0) d.push_back(m.disparity_q8 / 256.0);
  if (d.empty()) return {0.0, 1.0};
  std::sort(d.begin(), d.end());
  const auto at = [&](double q) { return d[static_cast<std::size_t>(q * static_cast<double>(d.size() - 1))]; };
  return {std::floor(at(0.02)), std::ceil(at(0.98))};
}

}  // namespace

cv::Mat draw_features(const Image& image, const Features& features, const FrontendTables& tables) {
  const std::string explanation = "colour = level, radius ~ level scale, tick = orientation";
  const int width = std::max(image.width(), kMinPanelWidth);
  const double font = fit_font({explanation}, width - 12, font_scale_for(width));
  const int line_height = line_height_for(font);
  const auto legend = layout_level_legend(tables, {6, image.height() + line_height}, width - 6, font, line_height);
  const int explanation_y = legend.back().origin.y + line_height;
  cv::Mat canvas(explanation_y + line_height / 2, width, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::Mat view = canvas(cv::Rect(0, 0, image.width(), image.height()));
  to_bgr(image).copyTo(view);
  draw_keypoints(view, features, tables);
  label(canvas, std::to_string(features.keypoints.size()) + " keypoints", {6, line_height}, font);
  draw_level_legend(canvas, legend, font);
  cv::putText(canvas, explanation, {6, explanation_y}, cv::FONT_HERSHEY_SIMPLEX, font, {200, 200, 200}, 1,
              cv::LINE_AA);
  return canvas;
}

cv::Mat draw_stereo(const Image& left, const Image& right, const StereoFeatures& stereo,
                    const FrontendTables& tables, const KnownDisparity& known) {
  // Image size (w, h) and panel size (pw, ph): panels are the image's size unless it is tiny.
  const int w = left.width(), h = left.height();
  const int pw = std::max(w, kMinPanelWidth), ph = std::max(h, kMinPanelHeight);
  cv::Mat canvas(2 * ph, 2 * pw, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::Mat top_left = canvas(cv::Rect(0, 0, w, h)), top_right = canvas(cv::Rect(pw, 0, w, h));
  cv::Mat bottom_left = canvas(cv::Rect(0, ph, w, h));
  to_bgr(left).copyTo(top_left);
  to_bgr(right).copyTo(top_right);
  to_bgr(left, 0.45).copyTo(bottom_left);
  draw_keypoints(top_left, stereo.left, tables);
  draw_keypoints(top_right, stereo.right, tables);

  const auto [lo, hi] = disparity_colour_range(stereo);
  const DisparityColours colours(lo, hi);
  const int matched = stereo.num_matches();

  // Every match as a dot on the dimmed left view; a sample (at most ~80) as lines across the views,
  // so the lines stay readable.
  const int line_step = std::max(1, matched / 80);
  int seen = 0, wrong = 0;
  for (std::size_t i = 0; i < stereo.matches.size(); ++i) {
    const StereoMatch& m = stereo.matches[i];
    if (m.disparity_q8 < 0) continue;
    const double d = m.disparity_q8 / 256.0;
    const double xl = stereo.left.level0_x(i, tables), yl = stereo.left.level0_y(i, tables);
    const cv::Scalar colour = colours(d);
    cv::circle(bottom_left, fixed_point(xl, yl), static_cast<int>(2.5 * kOne), colour, cv::FILLED, cv::LINE_AA,
               kShift);
    if (known.disparity_px != nullptr) {
      const int px = std::clamp(static_cast<int>(std::lround(xl)), 0, w - 1);
      const int py = std::clamp(static_cast<int>(std::lround(yl)), 0, h - 1);
      const int truth = (*known.disparity_px)[static_cast<std::size_t>(py) * known.width + px];
      if (std::abs(d - truth) > 1.0) {
        cv::drawMarker(bottom_left, cv::Point(px, py), {0, 0, 255}, cv::MARKER_TILTED_CROSS, 9, 2, cv::LINE_AA);
        ++wrong;
      }
    }
    if (seen++ % line_step == 0 && m.right_index >= 0) {
      const auto r = static_cast<std::size_t>(m.right_index);
      const double xr = stereo.right.level0_x(r, tables) + pw, yr = stereo.right.level0_y(r, tables);
      cv::line(canvas, fixed_point(xl, yl), fixed_point(xr, yr), colour, 1, cv::LINE_AA, kShift);
    }
  }

  // Captions and the legend panel (bottom right), with one font that fits the panel width.
  const std::string matches_caption = std::to_string(matched) + " matches, coloured by disparity";
  const std::string wrong_caption = std::to_string(wrong) + " off the known disparity by > 1 px";
  const std::string keypoint_caption = "keypoints: colour = level, radius ~ scale";
  const double font = fit_font({matches_caption, "     " + wrong_caption, keypoint_caption}, pw - 24, font_scale_for(pw));
  const int line_height = line_height_for(font);
  label(canvas, "left: " + std::to_string(stereo.left.keypoints.size()) + " keypoints", {6, line_height}, font);
  label(canvas, "right: " + std::to_string(stereo.right.keypoints.size()) + " keypoints", {pw + 6, line_height}, font);
  label(canvas, matches_caption, {6, ph + line_height}, font);

  const cv::Scalar text_colour(230, 230, 230);
  auto text = [&](const std::string& t, cv::Point at) {
    cv::putText(canvas, t, at, cv::FONT_HERSHEY_SIMPLEX, font, text_colour, 1, cv::LINE_AA);
  };
  int y = ph + line_height + 4;
  text("disparity (level-0 px)", {pw + 12, y});
  const int bar_left = pw + 12, bar_width = pw - 24, bar_top = y + line_height / 3, bar_height = line_height;
  for (int x = 0; x < bar_width; ++x)
    cv::line(canvas, {bar_left + x, bar_top}, {bar_left + x, bar_top + bar_height},
             colours(colours.lo() + (colours.hi() - colours.lo()) * x / std::max(1, bar_width - 1)));
  y = bar_top + bar_height + line_height;
  char range[64];
  std::snprintf(range, sizeof range, "%.0f", colours.lo());
  text(range, {bar_left, y});
  std::snprintf(range, sizeof range, "%.0f", colours.hi());
  int baseline = 0;
  text(range, {bar_left + bar_width - cv::getTextSize(range, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline).width, y});
  y += line_height + line_height / 3;
  if (known.disparity_px != nullptr) {
    cv::drawMarker(canvas, {pw + 18, y - line_height / 3}, {0, 0, 255}, cv::MARKER_TILTED_CROSS, 9, 2, cv::LINE_AA);
    text(wrong_caption, {pw + 30, y});
    y += line_height + line_height / 3;
  }
  text(keypoint_caption, {pw + 12, y});
  y += line_height;
  text("tick = orientation", {pw + 12, y});
  y += line_height + line_height / 3;
  draw_level_legend(canvas, layout_level_legend(tables, {pw + 12, y}, 2 * pw - 12, font, line_height), font);
  return canvas;
}

}  // namespace porta::app
