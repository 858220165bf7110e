// The candidate lookup of triangulation's epipolar search (triangulation_search.cpp). Private to
// slam/mapping/.
//
// The search asks, for each free feature of one keyframe, which free features of a neighbour lie
// within a narrow band (a few pixels) around an epipolar line. A scan of every feature makes that
// quadratic in the feature count. But every epipolar line of the pair passes through the epipole,
// so a point at radius r from the epipole can only be within w of a line whose direction is within
// asin(w / r) of the point's own direction from the epipole. The index keeps the points in rings of
// radius around the epipole, each sorted by direction, and visits per ring only that window:
// about a tenth of the features on KITTI-sized images. The caller applies its exact test to what
// is visited, so it finds what a full scan finds.
#pragma once

#include <Eigen/Core>
#include <array>
#include <span>
#include <vector>

namespace porta::slam::mapping {

class EpipolarPencilIndex {
 public:
  /// Points (u[j], v[j]) and the epipole in pixels; `max_half_width_px` bounds the band
  /// half-width of every later query (finite, >= 0). An epipole that is not finite or lies more
  /// than 1e6 px out (a sideways motion) leaves one range of all points, visited whole. Throws
  /// std::invalid_argument on spans of different lengths, a point that is not finite or a bad
  /// half-width.
  EpipolarPencilIndex(std::span<const double> u, std::span<const double> v, const Eigen::Vector2d& epipole,
                      double max_half_width_px);

  /// The points in the index's order: order()[k] is the index j of the point at position k.
  const std::vector<int>& order() const { return order_; }

  /// Calls visit(first, last) for ranges [first, last) of positions that together hold every
  /// point whose distance to the line line.x() u + line.y() v + line.z() = 0 is below the
  /// half-width given at construction (and some other points); a position is in at most one
  /// range. A line with line.x() = line.y() = 0, or not finite, visits nothing.
  template <class Visit>
  void visit_band(const Eigen::Vector3d& line, Visit&& visit) const {
    Ranges ranges;
    const int count = band_ranges(line, ranges);
    for (int i = 0; i < count; ++i)
      visit(ranges[static_cast<std::size_t>(i)].first, ranges[static_cast<std::size_t>(i)].last);
  }

  static constexpr std::size_t kRings = 8;
  /// Direction buckets per ring: a window's ends are looked up, not searched for.
  static constexpr std::size_t kBuckets = 128;

 private:
  struct Range {
    int first = 0, last = 0;
  };
  using Ranges = std::array<Range, 2 * kRings>;
  /// Fills the ranges of visit_band (at most two per ring, none empty); returns their count.
  int band_ranges(const Eigen::Vector3d& line, Ranges& ranges) const;

  Eigen::Vector2d epipole_ = Eigen::Vector2d::Zero();
  bool pencil_ = false;  ///< false: one range, all points
  double reach_px_ = 0.0;
  std::array<int, kRings + 1> ring_start_{};  ///< offsets into order_
  /// Per ring r, entry r * (kBuckets + 1) + b: the first position of the ring whose direction is
  /// at least b pi / kBuckets (the ring's end for b = kBuckets).
  std::vector<int> bucket_start_;
  std::vector<int> order_;
};

}  // namespace porta::slam::mapping
