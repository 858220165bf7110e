// EpipolarPencilIndex (slam/mapping/epipolar_pencil_index.hpp): what triangulation's epipolar
// search visits must include every point a full scan finds in the band, each once, and should be a
// small part of the points when the epipole is in view.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "slam/mapping/epipolar_pencil_index.hpp"

namespace porta::slam::mapping {
namespace {

struct Points {
  std::vector<double> u, v;
};

/// `n` points spread over a KITTI-sized image, drawn u then v.
Points image_points(std::size_t n, std::mt19937& rng) {
  std::uniform_real_distribution<double> du(0.0, 1241.0), dv(0.0, 374.0);
  Points points;
  for (std::size_t i = 0; i < n; ++i) {
    const double u = du(rng);
    const double v = dv(rng);
    points.u.push_back(u);
    points.v.push_back(v);
  }
  return points;
}

/// The line through `through` at angle `angle`, as (a, b, c) with a u + b v + c = 0, scaled by
/// `scale` (epipolar lines from a fundamental matrix are not normalised).
Eigen::Vector3d line_through(const Eigen::Vector2d& through, double angle, double scale) {
  const Eigen::Vector2d normal(-std::sin(angle), std::cos(angle));
  return scale * Eigen::Vector3d(normal.x(), normal.y(), -normal.dot(through));
}

/// Positions visited for `line`, each checked to be in range and visited once; as indices j.
std::vector<int> visited(const EpipolarPencilIndex& index, const Eigen::Vector3d& line) {
  const auto n = static_cast<int>(index.order().size());
  std::vector<int> seen(static_cast<std::size_t>(n), 0);
  std::vector<int> out;
  index.visit_band(line, [&](int first, int last) {
    EXPECT_LE(0, first);
    EXPECT_LT(first, last);
    EXPECT_LE(last, n);
    for (int k = first; k < last; ++k) {
      EXPECT_EQ(++seen[static_cast<std::size_t>(k)], 1) << "position " << k << " visited twice";
      out.push_back(index.order()[static_cast<std::size_t>(k)]);
    }
  });
  std::sort(out.begin(), out.end());
  return out;
}

/// The indices a full scan finds strictly within `half_width` of the line.
std::vector<int> in_band(const Points& points, const Eigen::Vector3d& line, double half_width) {
  const double norm2 = line.x() * line.x() + line.y() * line.y();
  std::vector<int> out;
  for (std::size_t j = 0; j < points.u.size(); ++j) {
    const double num = line.x() * points.u[j] + line.y() * points.v[j] + line.z();
    if (num * num < half_width * half_width * norm2) out.push_back(static_cast<int>(j));
  }
  return out;
}

bool contains_all(const std::vector<int>& sorted, const std::vector<int>& wanted) {
  return std::includes(sorted.begin(), sorted.end(), wanted.begin(), wanted.end());
}

TEST(EpipolarPencilIndex, VisitsEveryPointOfTheBandForLinesThroughTheEpipole) {
  std::mt19937 rng(7);
  const Points points = image_points(1500, rng);
  // In the image (forward motion), beside it, and far out (a mostly sideways motion).
  const Eigen::Vector2d epipoles[] = {{620.0, 185.0}, {1500.0, -300.0}, {-4.0e4, 2.0e3}};
  std::uniform_real_distribution<double> angle(0.0, 2.0 * std::numbers::pi), scale(1e-4, 1e2);
  std::size_t visited_total = 0, lines = 0;
  for (const Eigen::Vector2d& epipole : epipoles) {
    for (const double half_width : {0.0, 1.96, 7.0}) {
      const EpipolarPencilIndex index(points.u, points.v, epipole, half_width);
      for (int trial = 0; trial < 300; ++trial) {
        const double a = angle(rng);
        const double s = scale(rng);
        const Eigen::Vector3d line = line_through(epipole, a, s);
        const std::vector<int> seen = visited(index, line);
        const std::vector<int> wanted = in_band(points, line, half_width);
        ASSERT_TRUE(contains_all(seen, wanted)) << "epipole " << epipole.transpose() << ", angle " << a;
        visited_total += seen.size();
        ++lines;
      }
    }
  }
  EXPECT_GT(visited_total, 0u);
  EXPECT_GT(lines, 0u);
}

TEST(EpipolarPencilIndex, VisitsEveryPointOfTheBandForLinesMissingTheEpipole) {
  // Rounding, or a line from other poses: the index widens its window by the line's distance
  // from the epipole.
  std::mt19937 rng(11);
  const Points points = image_points(800, rng);
  const Eigen::Vector2d epipole(600.0, 200.0);
  const EpipolarPencilIndex index(points.u, points.v, epipole, 3.0);
  std::uniform_real_distribution<double> angle(0.0, std::numbers::pi), offset(-400.0, 400.0);
  for (int trial = 0; trial < 500; ++trial) {
    const double a = angle(rng);
    const double dx = offset(rng);
    const double dy = offset(rng);
    const Eigen::Vector3d line = line_through(epipole + Eigen::Vector2d(dx, dy), a, 1.0);
    ASSERT_TRUE(contains_all(visited(index, line), in_band(points, line, 3.0))) << "trial " << trial;
  }
}

TEST(EpipolarPencilIndex, VisitsAFewPercentOfThePointsWhenTheEpipoleIsInView) {
  std::mt19937 rng(3);
  const Points points = image_points(1200, rng);
  const Eigen::Vector2d epipole(620.0, 185.0);
  const EpipolarPencilIndex index(points.u, points.v, epipole, 7.0);  // level 7's band: the widest
  std::size_t total = 0;
  const int lines = 180;
  for (int i = 0; i < lines; ++i) {
    total += visited(index, line_through(epipole, std::numbers::pi * i / lines, 1.0)).size();
  }
  const double share = static_cast<double>(total) / (lines * 1200.0);
  EXPECT_LT(share, 0.15) << "the index visits " << share * 100.0 << " % of the points per line";
}

// Half-widths close to a ring's inner radius give windows just under half a turn, whose two
// wrapped ends, rounded outwards to the direction buckets, can meet: still each point once.
TEST(EpipolarPencilIndex, WindowsOfNearlyHalfATurnVisitEachPointOnce) {
  std::mt19937 rng(11);
  const Eigen::Vector2d epipole(600.0, 180.0);
  Points points;
  std::uniform_real_distribution<double> radius(24.0, 48.0), angle(0.0, 2.0 * std::numbers::pi);
  for (int i = 0; i < 800; ++i) {
    const double r = radius(rng), a = angle(rng);
    points.u.push_back(epipole.x() + r * std::cos(a));
    points.v.push_back(epipole.y() + r * std::sin(a));
  }
  // The ring from 24 px: windows within two buckets of half a turn for half-widths of ~19.15-19.25
  // px (the reach adds a pixel), so the sweep crosses them.
  for (int step = 0; step <= 60; ++step) {
    const double half_width = 18.9 + 0.01 * step;
    const EpipolarPencilIndex index(points.u, points.v, epipole, half_width);
    for (int i = 0; i < 360; ++i) {
      const Eigen::Vector3d line = line_through(epipole, std::numbers::pi * (i + 0.37) / 360.0, 1.0);
      ASSERT_TRUE(contains_all(visited(index, line), in_band(points, line, half_width)))
          << "half-width " << half_width << ", line " << i;
    }
  }
}

TEST(EpipolarPencilIndex, AnEpipoleAtInfinityVisitsEveryPointInIndexOrder) {
  std::mt19937 rng(5);
  const Points points = image_points(50, rng);
  const double inf = std::numeric_limits<double>::infinity();
  // The search's sentinel for a camera centre in the other camera's focal plane, and infinity.
  for (const Eigen::Vector2d& epipole : {Eigen::Vector2d(-1e9, -1e9), Eigen::Vector2d(inf, 0.0)}) {
    const EpipolarPencilIndex index(points.u, points.v, epipole, 2.0);
    for (std::size_t k = 0; k < 50; ++k) EXPECT_EQ(index.order()[k], static_cast<int>(k));
    EXPECT_EQ(visited(index, Eigen::Vector3d(0.3, 1.0, -200.0)).size(), 50u);
  }
}

TEST(EpipolarPencilIndex, ADegenerateLineOrNoPointsVisitsNothing) {
  std::mt19937 rng(9);
  const Points points = image_points(20, rng);
  const EpipolarPencilIndex index(points.u, points.v, Eigen::Vector2d(600.0, 180.0), 2.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(visited(index, Eigen::Vector3d(0.0, 0.0, 5.0)).empty());
  EXPECT_TRUE(visited(index, Eigen::Vector3d(nan, 1.0, 5.0)).empty());
  const EpipolarPencilIndex empty({}, {}, Eigen::Vector2d(600.0, 180.0), 2.0);
  EXPECT_TRUE(visited(empty, Eigen::Vector3d(1.0, 1.0, -500.0)).empty());
}

TEST(EpipolarPencilIndex, RefusesMismatchedOrNonFiniteInput) {
  const std::vector<double> u = {1.0, 2.0}, v = {1.0};
  const Eigen::Vector2d epipole(0.0, 0.0);
  EXPECT_THROW(EpipolarPencilIndex(u, v, epipole, 1.0), std::invalid_argument);
  const std::vector<double> bad = {1.0, std::numeric_limits<double>::quiet_NaN()};
  EXPECT_THROW(EpipolarPencilIndex(u, bad, epipole, 1.0), std::invalid_argument);
  EXPECT_THROW(EpipolarPencilIndex(u, u, epipole, -1.0), std::invalid_argument);
  EXPECT_THROW(EpipolarPencilIndex(u, u, epipole, std::numeric_limits<double>::infinity()),
               std::invalid_argument);
}

}  // namespace
}  // namespace porta::slam::mapping
