#include "quality/metrics.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

namespace porta::quality {

bool project(const cv::Matx33d& h, const cv::Point2d& p, cv::Point2d& out) {
  const double w = h(2, 0) * p.x + h(2, 1) * p.y + h(2, 2);
  if (!(w > 1e-12)) return false;
  out.x = (h(0, 0) * p.x + h(0, 1) * p.y + h(0, 2)) / w;
  out.y = (h(1, 0) * p.x + h(1, 1) * p.y + h(1, 2)) / w;
  return true;
}

bool inside(const cv::Point2d& p, cv::Size size) {
  return p.x >= 0.0 && p.y >= 0.0 && p.x <= size.width - 1.0 && p.y <= size.height - 1.0;
}

CommonRegion common_region(const std::vector<cv::Point2d>& first, cv::Size first_size,
                           const std::vector<cv::Point2d>& second, cv::Size second_size,
                           const cv::Matx33d& h) {
  const cv::Matx33d h_inverse = h.inv();
  CommonRegion region;
  cv::Point2d q;
  for (int i = 0; i < static_cast<int>(first.size()); ++i)
    if (project(h, first[i], q) && inside(q, second_size)) region.first.push_back(i);
  for (int j = 0; j < static_cast<int>(second.size()); ++j)
    if (project(h_inverse, second[j], q) && inside(q, first_size)) region.second.push_back(j);
  return region;
}

namespace {

// Buckets of points on a square grid of `cell` px, so that all points within `cell` of a query
// are found in the 3x3 buckets around it.
class PointGrid {
 public:
  PointGrid(const std::vector<cv::Point2d>& points, const std::vector<int>& indices, double cell)
      : points_(points), cell_(cell) {
    for (int i : indices) buckets_[key(bucket(points[i].x), bucket(points[i].y))].push_back(i);
  }

  template <typename Visit>
  void near(const cv::Point2d& q, Visit&& visit) const {
    const long bx = bucket(q.x), by = bucket(q.y);
    for (long y = by - 1; y <= by + 1; ++y)
      for (long x = bx - 1; x <= bx + 1; ++x) {
        auto it = buckets_.find(key(x, y));
        if (it == buckets_.end()) continue;
        for (int j : it->second) visit(j, std::hypot(points_[j].x - q.x, points_[j].y - q.y));
      }
  }

 private:
  long bucket(double v) const { return static_cast<long>(std::floor(v / cell_)); }
  static long long key(long x, long y) { return (static_cast<long long>(y) << 32) ^ (x & 0xffffffffLL); }

  const std::vector<cv::Point2d>& points_;
  double cell_;
  std::unordered_map<long long, std::vector<int>> buckets_;
};

}  // namespace

Repeatability repeatability(const std::vector<cv::Point2d>& first, cv::Size first_size,
                            const std::vector<cv::Point2d>& second, cv::Size second_size,
                            const cv::Matx33d& h, double epsilon_px) {
  const CommonRegion region = common_region(first, first_size, second, second_size, h);
  Repeatability r;
  r.common_first = static_cast<int>(region.first.size());
  r.common_second = static_cast<int>(region.second.size());
  if (r.common_first == 0 || r.common_second == 0) return r;

  // Every pair within epsilon, then a greedy one-to-one assignment, closest pairs first (ties by
  // index), so that one point is never counted twice.
  const cv::Matx33d h_inverse = h.inv();
  const PointGrid grid(second, region.second, epsilon_px);
  std::vector<std::tuple<double, int, int, bool>> pairs;  // distance in the second image, i, j, symmetric
  cv::Point2d q, back;
  for (int i : region.first) {
    project(h, first[i], q);
    grid.near(q, [&](int j, double distance) {
      if (distance > epsilon_px) return;
      const bool symmetric = project(h_inverse, second[j], back) &&
                             std::hypot(back.x - first[i].x, back.y - first[i].y) <= epsilon_px;
      pairs.emplace_back(distance, i, j, symmetric);
    });
  }
  std::sort(pairs.begin(), pairs.end());
  auto assign = [&](bool symmetric_only) {
    std::vector<char> used_first(first.size(), 0), used_second(second.size(), 0);
    int repeated = 0;
    for (const auto& [distance, i, j, symmetric] : pairs) {
      if ((symmetric_only && !symmetric) || used_first[i] || used_second[j]) continue;
      used_first[i] = used_second[j] = 1;
      ++repeated;
    }
    return repeated;
  };
  const double common = std::min(r.common_first, r.common_second);
  r.repeated = assign(false);
  r.value = r.repeated / common;
  r.repeated_symmetric = assign(true);
  r.symmetric_value = r.repeated_symmetric / common;
  return r;
}

namespace {

int hamming(const std::uint8_t* a, const std::uint8_t* b, int bytes) {
  int d = 0;
  int k = 0;
  for (; k + 8 <= bytes; k += 8) {
    std::uint64_t x, y;
    std::memcpy(&x, a + k, 8);
    std::memcpy(&y, b + k, 8);
    d += std::popcount(x ^ y);
  }
  for (; k < bytes; ++k) d += std::popcount(static_cast<unsigned>(a[k] ^ b[k]));
  return d;
}

}  // namespace

std::vector<std::pair<int, int>> mutual_hamming_matches(const cv::Mat& first,
                                                        const std::vector<int>& first_rows,
                                                        const cv::Mat& second,
                                                        const std::vector<int>& second_rows) {
  if (first.type() != CV_8U || second.type() != CV_8U || first.cols != second.cols)
    throw std::invalid_argument("mutual_hamming_matches: descriptors must be CV_8U rows of equal width");
  const int bytes = first.cols;
  const std::size_t n1 = first_rows.size(), n2 = second_rows.size();
  std::vector<int> best_of_first(n1, -1), best_of_second(n2, -1);
  std::vector<int> distance_of_first(n1, 1 << 30), distance_of_second(n2, 1 << 30);
  for (std::size_t a = 0; a < n1; ++a) {
    const std::uint8_t* da = first.ptr<std::uint8_t>(first_rows[a]);
    for (std::size_t b = 0; b < n2; ++b) {
      const int d = hamming(da, second.ptr<std::uint8_t>(second_rows[b]), bytes);
      // Strict comparisons keep the lowest index on ties, on both sides.
      if (d < distance_of_first[a]) distance_of_first[a] = d, best_of_first[a] = static_cast<int>(b);
      if (d < distance_of_second[b]) distance_of_second[b] = d, best_of_second[b] = static_cast<int>(a);
    }
  }
  std::vector<std::pair<int, int>> matches;
  for (std::size_t a = 0; a < n1; ++a) {
    const int b = best_of_first[a];
    if (b >= 0 && best_of_second[b] == static_cast<int>(a))
      matches.emplace_back(first_rows[a], second_rows[b]);
  }
  return matches;
}

MatchingScore matching_score(const FeatureSet& first, cv::Size first_size, const FeatureSet& second,
                             cv::Size second_size, const cv::Matx33d& h, double correct_px) {
  const CommonRegion region = common_region(first.points, first_size, second.points, second_size, h);
  MatchingScore m;
  m.common_first = static_cast<int>(region.first.size());
  m.common_second = static_cast<int>(region.second.size());
  if (m.common_first == 0 || m.common_second == 0 || first.descriptors.empty() || second.descriptors.empty())
    return m;
  const auto matches =
      mutual_hamming_matches(first.descriptors, region.first, second.descriptors, region.second);
  m.mutual_matches = static_cast<int>(matches.size());
  cv::Point2d q;
  for (const auto& [i, j] : matches) {
    project(h, first.points[i], q);
    if (std::hypot(q.x - second.points[j].x, q.y - second.points[j].y) <= correct_px) ++m.correct_matches;
  }
  m.score = static_cast<double>(m.correct_matches) / m.common_first;
  m.precision = m.mutual_matches > 0 ? static_cast<double>(m.correct_matches) / m.mutual_matches : 0.0;
  return m;
}

StereoAccuracy stereo_accuracy(const StereoFeatures& stereo, const FrontendTables& tables,
                               const cv::Mat& true_disparity) {
  if (true_disparity.type() != CV_32F)
    throw std::invalid_argument("stereo_accuracy: true disparity must be CV_32F");
  StereoAccuracy a;
  a.left_keypoints = static_cast<int>(stereo.left.keypoints.size());
  a.right_keypoints = static_cast<int>(stereo.right.keypoints.size());
  std::vector<double> errors;
  const std::size_t levels = tables.scales_q16.size();
  a.evaluated_by_level.assign(levels, 0);
  a.within_1px_by_level.assign(levels, 0);
  a.within_half_px_by_level.assign(levels, 0);
  for (std::size_t i = 0; i < stereo.matches.size() && i < stereo.left.keypoints.size(); ++i) {
    if (stereo.matches[i].disparity_q8 < 0) continue;
    ++a.matches;
    a.fractional_disparities += stereo.matches[i].disparity_q8 % 256 != 0 ? 1 : 0;
    const int x = static_cast<int>(std::lround(stereo.left.level0_x(i, tables)));
    const int y = static_cast<int>(std::lround(stereo.left.level0_y(i, tables)));
    if (x < 0 || y < 0 || x >= true_disparity.cols || y >= true_disparity.rows) continue;
    const float truth = true_disparity.at<float>(y, x);
    if (truth <= 0.0f) continue;  // unknown
    const double error = std::abs(stereo.matches[i].disparity_q8 / 256.0 - truth);
    ++a.evaluated;
    a.within_1px += error <= 1.0 ? 1 : 0;
    a.within_half_px += error <= 0.5 ? 1 : 0;
    const std::size_t level = stereo.left.keypoints[i].level;
    if (level < levels) {
      ++a.evaluated_by_level[level];
      a.within_1px_by_level[level] += error <= 1.0 ? 1 : 0;
      a.within_half_px_by_level[level] += error <= 0.5 ? 1 : 0;
    }
    errors.push_back(error);
  }
  a.density = a.left_keypoints > 0 ? static_cast<double>(a.matches) / a.left_keypoints : 0.0;
  if (a.evaluated > 0) {
    a.fraction_within_1px = static_cast<double>(a.within_1px) / a.evaluated;
    a.fraction_within_half_px = static_cast<double>(a.within_half_px) / a.evaluated;
    std::nth_element(errors.begin(), errors.begin() + static_cast<long>(errors.size() / 2), errors.end());
    a.median_abs_error_px = errors[errors.size() / 2];
  }
  return a;
}

}  // namespace porta::quality
