// ATE, RPE and the KITTI odometry relative errors of paired poses (evaluation.hpp), written from
// their definitions: Sturm et al., "A benchmark for the evaluation of RGB-D SLAM systems" (IROS 2012)
// for ATE/RPE, Geiger et al., "Are we ready for autonomous driving?" (CVPR 2012) for KITTI.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "porta/slam/evaluation.hpp"

namespace porta::slam {

namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
// Path lengths are sums of many floating-point steps; a segment "reaches" its length when it is
// within this of it, so that a path of exact 1 m steps reaches 100 m at the 100th step.
constexpr double kLengthTolerance_m = 1e-6;

void check_paired(const std::vector<SE3>& gt, const std::vector<SE3>& est) {
  if (gt.size() != est.size())
    throw EvaluationError("paired poses expected: " + std::to_string(gt.size()) + " ground-truth poses but " +
                          std::to_string(est.size()) + " estimate poses");
}

// The first index j >= from with distances[j] >= target (distances non-decreasing), or npos.
std::size_t first_reaching(const std::vector<double>& distances, std::size_t from, double target) {
  const auto it = std::lower_bound(distances.begin() + static_cast<std::ptrdiff_t>(from), distances.end(),
                                   target - kLengthTolerance_m);
  return it == distances.end() ? std::string::npos : static_cast<std::size_t>(it - distances.begin());
}

std::string format_delta(double value, const char* unit) {
  char text[64];
  std::snprintf(text, sizeof text, "%g %s", value, unit);
  return text;
}

}  // namespace

ErrorStats error_stats(const std::vector<double>& errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t n = sorted.size();
  s.min = sorted.front();
  s.max = sorted.back();
  s.median = n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  double sum = 0.0, sum_sq = 0.0;
  for (const double e : sorted) {
    sum += e;
    sum_sq += e * e;
  }
  s.mean = sum / static_cast<double>(n);
  s.rmse = std::sqrt(sum_sq / static_cast<double>(n));
  double spread = 0.0;  // two passes: no cancellation when the errors are large and alike
  for (const double e : sorted) spread += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(spread / static_cast<double>(n));
  return s;
}

SE3 relative_pose_error(const SE3& gt_i, const SE3& gt_j, const SE3& est_i, const SE3& est_j, double scale) {
  const SE3 gt_motion = gt_i.inverse() * gt_j;
  SE3 est_motion = est_i.inverse() * est_j;
  est_motion.translation() *= scale;
  return gt_motion.inverse() * est_motion;
}

std::vector<double> cumulative_distances_m(const std::vector<SE3>& poses) {
  std::vector<double> d(poses.size(), 0.0);
  for (std::size_t k = 1; k < poses.size(); ++k)
    d[k] = d[k - 1] + (poses[k].translation() - poses[k - 1].translation()).norm();
  return d;
}

AteResult compute_ate(const std::vector<SE3>& gt, const std::vector<SE3>& est, const Alignment& alignment) {
  check_paired(gt, est);
  AteResult r;
  r.translation_errors_m.reserve(gt.size());
  r.rotation_errors_deg.reserve(gt.size());
  for (std::size_t k = 0; k < gt.size(); ++k) {
    const SE3 aligned = alignment.apply(est[k]);
    r.translation_errors_m.push_back((gt[k].translation() - aligned.translation()).norm());
    r.rotation_errors_deg.push_back(rotation_angle_rad(gt[k].linear().transpose() * aligned.linear()) *
                                    kDegPerRad);
  }
  r.translation_m = error_stats(r.translation_errors_m);
  r.rotation_deg = error_stats(r.rotation_errors_deg);
  return r;
}

RpeResult compute_rpe(const std::vector<SE3>& gt, const std::vector<SE3>& est, const RpeOptions& options,
                      double scale) {
  check_paired(gt, est);
  RpeResult r;
  const bool by_distance = options.delta_distance_m > 0.0;
  if (!by_distance && options.delta_frames < 1) throw EvaluationError("the RPE frame delta must be >= 1");
  if (by_distance && !std::isfinite(options.delta_distance_m))
    throw EvaluationError("the RPE distance delta must be finite");
  r.delta = by_distance ? format_delta(options.delta_distance_m, "m")
                        : format_delta(static_cast<double>(options.delta_frames),
                                       options.delta_frames == 1 ? "frame" : "frames");
  const std::vector<double> distances = by_distance ? cumulative_distances_m(gt) : std::vector<double>{};
  for (std::size_t i = 0; i < gt.size(); ++i) {
    std::size_t j = std::string::npos;
    if (by_distance) {
      j = first_reaching(distances, i + 1, distances[i] + options.delta_distance_m);
    } else if (i + options.delta_frames < gt.size()) {
      j = i + options.delta_frames;
    }
    if (j == std::string::npos) break;  // later starts cannot reach further either
    const SE3 error = relative_pose_error(gt[i], gt[j], est[i], est[j], scale);
    r.first.push_back(i);
    r.second.push_back(j);
    r.translation_errors_m.push_back(error.translation().norm());
    r.rotation_errors_deg.push_back(rotation_angle_rad(error.linear()) * kDegPerRad);
  }
  r.translation_m = error_stats(r.translation_errors_m);
  r.rotation_deg = error_stats(r.rotation_errors_deg);
  return r;
}

std::vector<double> kitti_segment_lengths_m() { return {100, 200, 300, 400, 500, 600, 700, 800}; }

KittiResult compute_kitti(const std::vector<SE3>& gt, const std::vector<SE3>& est, double scale) {
  check_paired(gt, est);
  KittiResult r;
  const std::vector<double> distances = cumulative_distances_m(gt);
  double t_sum = 0.0, r_sum = 0.0;  // of t_err (1) and r_err (rad/m) over all segments
  for (const double length : kitti_segment_lengths_m()) {
    KittiLengthStats stats;
    stats.length_m = length;
    double t_len = 0.0, r_len = 0.0;
    for (std::size_t start = 0; start < gt.size(); start += kKittiStartStep) {
      const std::size_t end = first_reaching(distances, start, distances[start] + length);
      if (end == std::string::npos) break;
      const SE3 error = relative_pose_error(gt[start], gt[end], est[start], est[end], scale);
      t_len += error.translation().norm() / length;
      r_len += rotation_angle_rad(error.linear()) / length;
      ++stats.segments;
    }
    if (stats.segments == 0) continue;
    t_sum += t_len;
    r_sum += r_len;
    r.segments += stats.segments;
    stats.translation_percent = 100.0 * t_len / static_cast<double>(stats.segments);
    stats.rotation_deg_per_100m = 100.0 * kDegPerRad * r_len / static_cast<double>(stats.segments);
    r.per_length.push_back(stats);
  }
  if (r.segments == 0) {
    char text[160];
    std::snprintf(text, sizeof text,
                  "no KITTI segments: the ground-truth path of the paired poses is %.1f m, shorter than the "
                  "shortest segment (100 m)",
                  distances.empty() ? 0.0 : distances.back());
    r.note = text;
    return r;
  }
  const double n = static_cast<double>(r.segments);
  r.translation_percent = 100.0 * t_sum / n;
  r.rotation_deg_per_m = kDegPerRad * r_sum / n;
  r.rotation_deg_per_100m = 100.0 * r.rotation_deg_per_m;
  return r;
}

}  // namespace porta::slam
