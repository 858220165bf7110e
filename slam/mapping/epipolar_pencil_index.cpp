// EpipolarPencilIndex; see epipolar_pencil_index.hpp.
//
// Why a window of asin(w / r) suffices: let the query line make distance d_e to the epipole and
// have direction phi. A point at radius r and direction theta from the epipole lies at
// r |sin(theta - phi)| from the parallel to the line through the epipole, so at least that minus
// d_e from the line itself. Within w of the line therefore means |sin(theta - phi)| < (w + d_e) / r
// <= (w + d_e) / r_ring for every point of a ring with inner radius r_ring. Directions are taken
// modulo pi (a line has no sense), and the reach adds one pixel so that rounding only widens it.
// The window's half-width is bounded from above by tan(asin x) = x / sqrt(1 - x^2) >= asin x (no
// asin per ring and query), and its ends are rounded outwards to the ring's direction buckets:
// both only widen the window, so the caller's exact test still sees every point a scan would.
#include "epipolar_pencil_index.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace porta::slam::mapping {
namespace {

constexpr double kRoundingMarginPx = 1.0;
constexpr double kFarEpipolePx = 1e6;
constexpr double kAngleMargin = 1e-9;
/// Widens a bucket lookup by this fraction of a bucket, against rounding at the boundaries.
constexpr double kBucketMargin = 1e-6;
/// Inner radii of the rings, px; the first ring is always visited whole.
constexpr double kRingRadii[] = {0.0, 24.0, 48.0, 96.0, 192.0, 384.0, 768.0, 1536.0};
static_assert(std::size(kRingRadii) == EpipolarPencilIndex::kRings);

/// The direction of (x, y) modulo pi, in [0, pi).
double direction_mod_pi(double x, double y) {
  double angle = std::atan2(y, x);
  if (angle < 0.0) angle += std::numbers::pi;
  if (angle >= std::numbers::pi) angle -= std::numbers::pi;
  return angle;
}

}  // namespace

EpipolarPencilIndex::EpipolarPencilIndex(std::span<const double> u, std::span<const double> v,
                                         const Eigen::Vector2d& epipole, double max_half_width_px)
    : epipole_(epipole), reach_px_(max_half_width_px + kRoundingMarginPx) {
  if (u.size() != v.size()) {
    throw std::invalid_argument("EpipolarPencilIndex: " + std::to_string(u.size()) + " u values but " +
                                std::to_string(v.size()) + " v values");
  }
  if (!std::isfinite(max_half_width_px) || max_half_width_px < 0.0) {
    throw std::invalid_argument("EpipolarPencilIndex: the band half-width must be finite and >= 0, got " +
                                std::to_string(max_half_width_px));
  }
  const std::size_t n = u.size();
  for (std::size_t j = 0; j < n; ++j) {
    if (!std::isfinite(u[j]) || !std::isfinite(v[j])) {
      throw std::invalid_argument("EpipolarPencilIndex: point " + std::to_string(j) + " is not finite");
    }
  }
  order_.resize(n);
  for (std::size_t j = 0; j < n; ++j) order_[j] = static_cast<int>(j);
  pencil_ = epipole.allFinite() && epipole.cwiseAbs().maxCoeff() <= kFarEpipolePx;
  if (!pencil_) return;  // band_ranges() gives all points, in index order

  // Ring, then direction, then index: a total order, so the layout does not depend on the sort.
  // The points are sorted as (ring, direction, index) records, not through an index array whose
  // comparisons would each fetch two points' keys from elsewhere.
  constexpr std::size_t rings = kRings;
  struct Entry {
    int ring;
    int index;
    double direction;
  };
  std::vector<Entry> entries(n);
  for (std::size_t j = 0; j < n; ++j) {
    const double dx = u[j] - epipole.x(), dy = v[j] - epipole.y();
    const double radius = std::hypot(dx, dy);
    const int ring = static_cast<int>(std::upper_bound(std::begin(kRingRadii), std::end(kRingRadii), radius) -
                                      std::begin(kRingRadii)) -
                     1;
    entries[j] = {ring, static_cast<int>(j), direction_mod_pi(dx, dy)};
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    if (a.ring != b.ring) return a.ring < b.ring;
    if (a.direction != b.direction) return a.direction < b.direction;
    return a.index < b.index;
  });
  for (std::size_t k = 0; k < n; ++k) {
    order_[k] = entries[k].index;
    ++ring_start_[static_cast<std::size_t>(entries[k].ring) + 1];
  }
  for (std::size_t r = 1; r <= rings; ++r) ring_start_[r] += ring_start_[r - 1];
  // Bucket b of ring r starts at the ring's first position whose direction is at least
  // b pi / kBuckets: one walk along each ring, the directions ascending.
  bucket_start_.resize(rings * (kBuckets + 1));
  for (std::size_t r = 0; r < rings; ++r) {
    int k = ring_start_[r];
    const int end = ring_start_[r + 1];
    for (std::size_t b = 0; b < kBuckets; ++b) {
      const double angle = std::numbers::pi * static_cast<double>(b) / static_cast<double>(kBuckets);
      while (k < end && entries[static_cast<std::size_t>(k)].direction < angle) ++k;
      bucket_start_[r * (kBuckets + 1) + b] = k;
    }
    bucket_start_[r * (kBuckets + 1) + kBuckets] = end;
  }
}

int EpipolarPencilIndex::band_ranges(const Eigen::Vector3d& line, Ranges& ranges) const {
  int count = 0;
  const auto add = [&](int first, int last) {
    if (first < last) ranges[static_cast<std::size_t>(count++)] = {first, last};
  };
  if (order_.empty() || !line.allFinite()) return 0;
  const double a = line.x(), b = line.y(), c = line.z();
  const double norm = std::hypot(a, b);
  if (!(norm > 0.0)) return 0;
  if (!pencil_) {
    add(0, static_cast<int>(order_.size()));
    return count;
  }
  const double epipole_distance = std::abs(a * epipole_.x() + b * epipole_.y() + c) / norm;
  const double reach = reach_px_ + epipole_distance;
  const double line_direction = direction_mod_pi(b, -a);
  constexpr double pi = std::numbers::pi;
  constexpr double buckets_per_radian = static_cast<double>(kBuckets) / pi;
  constexpr auto last_bucket = static_cast<double>(kBuckets - 1);
  for (std::size_t r = 0; r < kRings; ++r) {
    const int begin = ring_start_[r], end = ring_start_[r + 1];
    if (begin == end) continue;
    double half = pi;
    if (reach < kRingRadii[r]) {
      const double x = reach / kRingRadii[r];
      half = x / std::sqrt(1.0 - x * x) + kAngleMargin;  // >= asin(x)
    }
    if (2.0 * half >= pi) {  // the window covers every direction
      add(begin, end);
      continue;
    }
    const int* bucket = bucket_start_.data() + r * (kBuckets + 1);
    // The first position at or before the first direction >= angle, and the first position
    // after the last direction <= angle, for angle in [0, pi).
    const auto from = [&](double angle) {
      return bucket[static_cast<std::size_t>(std::clamp(std::floor(angle * buckets_per_radian - kBucketMargin), 0.0,
                                                        last_bucket))];
    };
    const auto to = [&](double angle) {
      return bucket[static_cast<std::size_t>(std::clamp(std::floor(angle * buckets_per_radian + kBucketMargin), 0.0,
                                                        last_bucket)) +
                    1];
    };
    // The window [direction - half, direction + half] modulo pi: one range, or two when it wraps
    // (one when the rounded ends of the two meet: no position may be visited twice).
    const double low = line_direction - half, high = line_direction + half;
    if (low < 0.0 || high >= pi) {
      const int head_end = to(low < 0.0 ? high : high - pi);
      const int tail_begin = from(low < 0.0 ? low + pi : low);
      if (head_end >= tail_begin) {
        add(begin, end);
      } else {
        add(begin, head_end);
        add(tail_begin, end);
      }
    } else {
      add(from(low), to(high));
    }
  }
  return count;
}

}  // namespace porta::slam::mapping
