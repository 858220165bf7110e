// PNG plots of an evaluation (eval_report.hpp), drawn with OpenCV's imgproc on a white canvas: a
// small chart helper (axes with "nice" ticks, grid, polylines, legend) and the three figures.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "porta/slam/eval_report.hpp"
#include "porta/slam/atomic_file.hpp"

namespace porta::slam {

namespace {

constexpr int kWidth = 1000;
constexpr int kHeight = 800;
constexpr int kLeft = 110;  // room for the y tick labels and the y label
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kGroundTruthColour(60, 60, 60);  // dark grey (BGR)
const cv::Scalar kEstimateColour(200, 90, 0);     // blue
const cv::Scalar kErrorColour(40, 40, 210);       // red
const cv::Scalar kRmseColour(0, 140, 0);          // green
const cv::Scalar kStartColour(0, 170, 0);

std::string format_number(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", std::max(0, decimals), value);
  std::string s = text;
  if (s == "-0" || s.rfind("-0.", 0) == 0) {  // no "-0.0" tick labels
    bool all_zero = true;
    for (const char c : s) all_zero &= (c == '-' || c == '0' || c == '.');
    if (all_zero) s.erase(0, 1);
  }
  return s;
}

void put_text(cv::Mat& canvas, const std::string& text, cv::Point at, double scale, const cv::Scalar& colour,
              int thickness = 1) {
  cv::putText(canvas, text, at, kFont, scale, colour, thickness, cv::LINE_AA);
}

cv::Size text_size(const std::string& text, double scale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, thickness, &baseline);
}

/// An axis range and its ticks at 1, 2 or 5 times a power of ten.
struct Ticks {
  double step = 1.0;
  int decimals = 0;
  std::vector<double> values;
};

Ticks nice_ticks(double lo, double hi, int target) {
  Ticks t;
  const double raw = (hi - lo) / std::max(1, target);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (const double m : {1.0, 2.0, 5.0, 10.0})
    if (m * power >= raw) {
      step = m * power;
      break;
    }
  t.step = step;
  t.decimals = static_cast<int>(std::max(0.0, -std::floor(std::log10(step) + 1e-9)));
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + 1e-9 * step; v += step) t.values.push_back(v);
  return t;
}

/// A chart area: data ranges mapped onto a pixel rectangle (y grows upwards).
struct Axes {
  cv::Rect area;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;

  cv::Point2d to_pixel(double x, double y) const {
    return {area.x + (x - x0) / (x1 - x0) * area.width,
            area.y + area.height - (y - y0) / (y1 - y0) * area.height};
  }
};

// Pixel coordinates in 1/16 px (cv::LINE_AA with shift 4), so that lines stay smooth.
constexpr int kShift = 4;
cv::Point fixed_point(cv::Point2d p) { return {cvRound(p.x * 16.0), cvRound(p.y * 16.0)}; }

void draw_axes(cv::Mat& canvas, const Axes& axes, const std::string& x_label, const std::string& y_label) {
  const double scale = 0.5;
  const Ticks xt = nice_ticks(axes.x0, axes.x1, std::max(4, axes.area.width / 110));
  const Ticks yt = nice_ticks(axes.y0, axes.y1, std::max(4, axes.area.height / 80));
  for (const double x : xt.values) {
    const int px = cvRound(axes.to_pixel(x, axes.y0).x);
    cv::line(canvas, {px, axes.area.y}, {px, axes.area.y + axes.area.height}, kGrid, 1);
    cv::line(canvas, {px, axes.area.y + axes.area.height}, {px, axes.area.y + axes.area.height + 5}, kBlack,
             1);
    const std::string label = format_number(x, xt.decimals);
    const cv::Size size = text_size(label, scale);
    put_text(canvas, label, {px - size.width / 2, axes.area.y + axes.area.height + 10 + size.height}, scale,
             kBlack);
  }
  int widest_y_label = 0;
  for (const double y : yt.values) {
    const int py = cvRound(axes.to_pixel(axes.x0, y).y);
    cv::line(canvas, {axes.area.x, py}, {axes.area.x + axes.area.width, py}, kGrid, 1);
    cv::line(canvas, {axes.area.x - 5, py}, {axes.area.x, py}, kBlack, 1);
    const std::string label = format_number(y, yt.decimals);
    const cv::Size size = text_size(label, scale);
    widest_y_label = std::max(widest_y_label, size.width);
    put_text(canvas, label, {axes.area.x - 9 - size.width, py + size.height / 2}, scale, kBlack);
  }
  cv::rectangle(canvas, axes.area, kBlack, 1);

  const double label_scale = 0.6;
  const cv::Size xs = text_size(x_label, label_scale);
  put_text(canvas, x_label,
           {axes.area.x + (axes.area.width - xs.width) / 2, axes.area.y + axes.area.height + 50}, label_scale,
           kBlack);
  // The y label, turned to read upwards: drawn into a strip, then rotated.
  const cv::Size ys = text_size(y_label, label_scale);
  cv::Mat strip(ys.height + 8, ys.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
  put_text(strip, y_label, {2, ys.height + 2}, label_scale, kBlack);
  cv::Mat turned;
  cv::rotate(strip, turned, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int left = std::max(0, axes.area.x - 9 - widest_y_label - 10 - turned.cols);
  const int top =
      std::clamp(axes.area.y + (axes.area.height - turned.rows) / 2, 0, canvas.rows - turned.rows);
  if (left + turned.cols <= canvas.cols && turned.rows <= canvas.rows)
    turned.copyTo(canvas(cv::Rect(left, top, turned.cols, turned.rows)));
}

void draw_polyline(cv::Mat& canvas, const Axes& axes, const std::vector<cv::Point2d>& points,
                   const cv::Scalar& colour, int thickness) {
  if (points.empty()) return;
  std::vector<cv::Point> pixels;
  pixels.reserve(points.size());
  for (const cv::Point2d& p : points) pixels.push_back(fixed_point(axes.to_pixel(p.x, p.y)));
  if (pixels.size() == 1) {
    cv::circle(canvas, pixels[0], thickness * 16, colour, cv::FILLED, cv::LINE_AA, kShift);
    return;
  }
  cv::polylines(canvas, pixels, false, colour, thickness, cv::LINE_AA, kShift);
}

void draw_dashed_horizontal(cv::Mat& canvas, const Axes& axes, double y, const cv::Scalar& colour) {
  const int py = cvRound(axes.to_pixel(axes.x0, y).y);
  for (int x = axes.area.x; x < axes.area.x + axes.area.width; x += 14)
    cv::line(canvas, {x, py}, {std::min(x + 8, axes.area.x + axes.area.width), py}, colour, 2, cv::LINE_AA);
}

struct LegendEntry {
  std::string label;
  cv::Scalar colour;
  enum class Mark { line, dashed, dot } mark = Mark::line;
};

// The legend goes into the corner of the chart that hides the fewest data points.
void draw_legend(cv::Mat& canvas, const Axes& axes, const std::vector<LegendEntry>& entries,
                 const std::vector<const std::vector<cv::Point2d>*>& data) {
  const double scale = 0.55;
  int width = 0;
  for (const LegendEntry& e : entries) width = std::max(width, text_size(e.label, scale).width);
  const int row = 24;
  const cv::Size size(width + 54, row * static_cast<int>(entries.size()) + 10);
  const int left = axes.area.x + 10, right = axes.area.x + axes.area.width - size.width - 10;
  const int top = axes.area.y + 10, bottom = axes.area.y + axes.area.height - size.height - 10;
  cv::Rect box;
  std::size_t fewest = std::numeric_limits<std::size_t>::max();
  for (const cv::Point corner :
       {cv::Point(right, top), cv::Point(left, top), cv::Point(right, bottom), cv::Point(left, bottom)}) {
    const cv::Rect candidate(corner, size);
    const cv::Rect margin(candidate.x - 8, candidate.y - 8, candidate.width + 16, candidate.height + 16);
    std::size_t hidden = 0;
    for (const auto* points : data)
      for (const cv::Point2d& p : *points) hidden += margin.contains(axes.to_pixel(p.x, p.y)) ? 1 : 0;
    if (hidden < fewest) {
      fewest = hidden;
      box = candidate;
    }
  }
  cv::rectangle(canvas, box, cv::Scalar(255, 255, 255), cv::FILLED);
  cv::rectangle(canvas, box, cv::Scalar(150, 150, 150), 1);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const LegendEntry& e = entries[k];
    const int y = box.y + 5 + row * static_cast<int>(k) + row / 2;
    const int x = box.x + 8;
    switch (e.mark) {
      case LegendEntry::Mark::line:
        cv::line(canvas, {x, y}, {x + 30, y}, e.colour, 2, cv::LINE_AA);
        break;
      case LegendEntry::Mark::dashed:
        cv::line(canvas, {x, y}, {x + 10, y}, e.colour, 2, cv::LINE_AA);
        cv::line(canvas, {x + 18, y}, {x + 30, y}, e.colour, 2, cv::LINE_AA);
        break;
      case LegendEntry::Mark::dot:
        cv::circle(canvas, {x + 15, y}, 6, e.colour, cv::FILLED, cv::LINE_AA);
        break;
    }
    put_text(canvas, e.label, {x + 40, y + 6}, scale, kBlack);
  }
}

void draw_title(cv::Mat& canvas, const std::string& title, const std::string& subtitle) {
  const cv::Size size = text_size(title, 0.7, 2);
  put_text(canvas, title, {(canvas.cols - size.width) / 2, 30}, 0.7, kBlack, 2);
  if (!subtitle.empty()) {
    const cv::Size sub = text_size(subtitle, 0.5);
    put_text(canvas, subtitle, {(canvas.cols - sub.width) / 2, 56}, 0.5, cv::Scalar(70, 70, 70));
  }
}

void save_png(const std::string& path, const cv::Mat& canvas) {
  // Encoded in memory, then written whole or not at all (atomic_file.hpp).
  std::vector<std::uint8_t> png;
  bool ok = false;
  try {
    ok = cv::imencode(".png", canvas, png);
  } catch (const cv::Exception& e) {
    throw EvaluationError("cannot write the plot '" + path + "': PNG encoding failed (" + e.err + ")");
  }
  if (!ok) throw EvaluationError("cannot write the plot '" + path + "': PNG encoding failed");
  try {
    write_file_atomically(path, png);
  } catch (const AtomicWriteError& e) {
    throw EvaluationError(std::string("plot: ") + e.what());
  }
}

std::string fmt(const char* format, double value) {
  if (std::abs(value) < 1e-9) value = 0.0;  // rounding noise of an exact result: "0", not "5e-18"
  char text[96];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

// ---- (a) top view ----------------------------------------------------------------------------------

// The two coordinate axes in which the ground truth spreads most (the ground plane for a KITTI
// camera with y down as for an EuRoC body frame with z up), in increasing order.
std::array<int, 2> ground_plane_axes(const std::vector<Eigen::Vector3d>& positions) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : positions) mean += p;
  mean /= static_cast<double>(std::max<std::size_t>(1, positions.size()));
  Eigen::Vector3d variance = Eigen::Vector3d::Zero();
  for (const auto& p : positions) variance += (p - mean).cwiseAbs2();
  int least = 2;  // ties: drop z, then y
  for (int axis = 1; axis >= 0; --axis)
    if (variance(axis) < variance(least)) least = axis;
  std::array<int, 2> axes{};
  for (int axis = 0, n = 0; axis < 3; ++axis)
    if (axis != least) axes[static_cast<std::size_t>(n++)] = axis;
  return axes;
}

std::string trajectory_plot(const std::string& path, const EvaluationResult& r, const std::string& title) {
  cv::Mat canvas(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto [ax, ay] = ground_plane_axes(r.gt_positions);
  const char* names[] = {"x", "y", "z"};

  std::vector<cv::Point2d> gt, est;
  for (const auto& p : r.gt_positions) gt.emplace_back(p(ax), p(ay));
  for (const auto& p : r.aligned_estimate_positions) est.emplace_back(p(ax), p(ay));

  double x0 = std::numeric_limits<double>::max(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const auto* points : {&gt, &est})
    for (const cv::Point2d& p : *points) {
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
  Axes axes;
  axes.area = cv::Rect(kLeft, 80, kWidth - kLeft - 40, kHeight - 170);
  // Equal metres per pixel on both axes: widen the tighter range about its centre.
  const double span = std::max({x1 - x0, y1 - y0, 1e-3}) * 1.06;
  const double per_pixel = std::max(span / axes.area.width, span / axes.area.height);
  const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
  axes.x0 = cx - 0.5 * per_pixel * axes.area.width;
  axes.x1 = cx + 0.5 * per_pixel * axes.area.width;
  axes.y0 = cy - 0.5 * per_pixel * axes.area.height;
  axes.y1 = cy + 0.5 * per_pixel * axes.area.height;

  draw_axes(canvas, axes, std::string(names[ax]) + " (m)", std::string(names[ay]) + " (m)");
  draw_polyline(canvas, axes, gt, kGroundTruthColour, 3);
  draw_polyline(canvas, axes, est, kEstimateColour, 2);
  if (!gt.empty()) {
    const cv::Point2d start = axes.to_pixel(gt.front().x, gt.front().y);
    cv::circle(canvas, fixed_point(start), 7 * 16, kStartColour, cv::FILLED, cv::LINE_AA, kShift);
    cv::circle(canvas, fixed_point(start), 7 * 16, kBlack, 1, cv::LINE_AA, kShift);
  }
  draw_legend(canvas, axes,
              {{"ground truth", kGroundTruthColour, LegendEntry::Mark::line},
               {std::string("estimate (") + to_string(r.alignment.method) + " aligned)", kEstimateColour,
                LegendEntry::Mark::line},
               {"start", kStartColour, LegendEntry::Mark::dot}},
              {&gt, &est});
  std::string subtitle = "top view (" + std::string(names[ax]) + "-" + names[ay] + " plane), ATE RMSE " +
                         fmt("%.4g m", r.ate.translation_m.rmse) + ", " +
                         std::to_string(r.association.matched()) + " poses, ground-truth path " +
                         fmt("%.1f m", r.gt_path_length_m);
  if (r.alignment.method == AlignmentMethod::sim3) subtitle += ", scale " + fmt("%.4f", r.alignment.scale);
  draw_title(canvas, title, subtitle);
  save_png(path, canvas);
  return path;
}

// ---- (b) ATE along the trajectory, (c) RPE ---------------------------------------------------------

Axes error_axes(cv::Rect area, double x0, double x1, const std::vector<double>& errors, double floor_max) {
  Axes axes;
  axes.area = area;
  axes.x0 = x0;
  axes.x1 = x1 > x0 ? x1 : x0 + 1.0;
  const double max = errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end());
  axes.y0 = 0.0;
  axes.y1 = std::max(max * 1.08, floor_max);
  return axes;
}

// `smallest_top`: the y axis reaches at least this high, so that near-zero errors (an estimate
// that equals the ground truth) show as a flat line at 0, not as noise blown up to fill the chart.
void error_chart(cv::Mat& canvas, cv::Rect area, const std::vector<double>& x,
                 const std::vector<double>& errors, double rmse, const std::string& x_label,
                 const std::string& y_label, const char* unit_format, double smallest_top) {
  const Axes axes =
      error_axes(area, x.empty() ? 0.0 : x.front(), x.empty() ? 1.0 : x.back(), errors, smallest_top);
  draw_axes(canvas, axes, x_label, y_label);
  std::vector<cv::Point2d> points;
  for (std::size_t k = 0; k < errors.size(); ++k) points.emplace_back(x[k], errors[k]);
  draw_polyline(canvas, axes, points, kErrorColour, 1);
  draw_dashed_horizontal(canvas, axes, rmse, kRmseColour);
  draw_legend(canvas, axes,
              {{"error", kErrorColour, LegendEntry::Mark::line},
               {"RMSE " + fmt(unit_format, rmse), kRmseColour, LegendEntry::Mark::dashed}},
              {&points});
}

// The x axis of error plots: time when the ground truth has times, else distance along it.
struct XAxis {
  std::vector<double> values;  // per pair
  std::string label;
};

XAxis along_axis(const EvaluationResult& r) {
  if (r.pair_has_times) return {r.pair_time_s, "time (s)"};
  return {r.pair_distance_m, "distance along the ground truth (m)"};
}

std::string ate_plot(const std::string& path, const EvaluationResult& r, const std::string& title) {
  cv::Mat canvas(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  const XAxis along = along_axis(r);
  error_chart(canvas, cv::Rect(kLeft, 80, kWidth - kLeft - 40, kHeight - 170), along.values,
              r.ate.translation_errors_m, r.ate.translation_m.rmse, along.label, "ATE (m)", "%.4g m", 1e-3);
  const ErrorStats& s = r.ate.translation_m;
  draw_title(canvas, title,
             "absolute trajectory error after " + std::string(to_string(r.alignment.method)) +
                 " alignment: RMSE " + fmt("%.4g", s.rmse) + fmt(", mean %.4g", s.mean) +
                 fmt(", median %.4g", s.median) + fmt(", max %.4g m", s.max));
  save_png(path, canvas);
  return path;
}

std::string rpe_plot(const std::string& path, const EvaluationResult& r, const std::string& title) {
  cv::Mat canvas(kHeight, kWidth, CV_8UC3, cv::Scalar(255, 255, 255));
  const XAxis along = along_axis(r);
  std::vector<double> x;
  for (const std::size_t i : r.rpe.first) x.push_back(along.values[i]);
  const int panel = (kHeight - 80 - 2 * 85) / 2;
  error_chart(canvas, cv::Rect(kLeft, 80, kWidth - kLeft - 40, panel), x, r.rpe.translation_errors_m,
              r.rpe.translation_m.rmse, along.label, "RPE translation (m)", "%.4g m", 1e-3);
  error_chart(canvas, cv::Rect(kLeft, 80 + panel + 85, kWidth - kLeft - 40, panel), x,
              r.rpe.rotation_errors_deg, r.rpe.rotation_deg.rmse, along.label, "RPE rotation (deg)",
              "%.4g deg", 1e-3);
  draw_title(canvas, title,
             "relative pose error over " + r.rpe.delta + ": translation RMSE " +
                 fmt("%.4g m", r.rpe.translation_m.rmse) + ", rotation RMSE " +
                 fmt("%.4g deg", r.rpe.rotation_deg.rmse) + " (" + std::to_string(r.rpe.translation_m.count) +
                 " pairs)");
  save_png(path, canvas);
  return path;
}

}  // namespace

bool evaluation_plots_available() { return true; }

std::vector<std::string> write_evaluation_plots(const std::string& folder, const EvaluationResult& result,
                                                const std::string& title) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(folder, ec) && !fs::is_directory(folder, ec))
    throw EvaluationError("cannot write plots into '" + folder + "': it is a file, not a folder");
  fs::create_directories(folder, ec);
  if (ec) throw EvaluationError("cannot create the plot folder '" + folder + "': " + ec.message());
  const fs::path dir(folder);
  std::vector<std::string> written;
  written.push_back(trajectory_plot((dir / "trajectory.png").string(), result, title));
  written.push_back(ate_plot((dir / "ate.png").string(), result, title));
  if (!result.rpe.first.empty()) written.push_back(rpe_plot((dir / "rpe.png").string(), result, title));
  return written;
}

}  // namespace porta::slam
