// The run's top view (porta/slam/top_view.hpp): the x-z plane seen from above with z up, the
// trajectories whole, stray map points clipped, ground truth under the estimate, and a picture
// even for an empty run.
#if PORTA_EVAL_BUILT
#include "porta/slam/top_view.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

namespace porta::slam {
namespace {

using Pixel = std::array<std::uint8_t, 3>;

Pixel at(const RgbImage& image, double x, double y) {
  const std::uint8_t* p = image.pixel(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)));
  return {p[0], p[1], p[2]};
}

Pixel of(const std::uint8_t (&c)[3]) { return {c[0], c[1], c[2]}; }

/// A drive 40 m forward (z), then 20 m to the right (x), with walls of points beside it.
TopViewInput l_shaped_drive() {
  TopViewInput input;
  for (int k = 0; k <= 40; ++k) input.estimate.emplace_back(0.0, 0.0, k);
  for (int k = 1; k <= 20; ++k) input.estimate.emplace_back(k, 0.0, 40.0);
  for (int k = 0; k <= 400; ++k) {
    input.map_points.emplace_back(-5.0, -1.0, 0.1 * k);
    input.map_points.emplace_back(5.0, -1.0, 0.1 * k);
  }
  input.title = "an L-shaped drive";
  return input;
}

TEST(TopView, ZIsUpXIsRightAndTheTrajectoryIsDrawnWhereTheFrameSays) {
  TopViewFrame frame;
  const RgbImage image = draw_top_view(l_shaped_drive(), 600, &frame);
  ASSERT_EQ(image.rgb.size(), static_cast<std::size_t>(image.width) * image.height * 3);
  // z up: the end of the forward leg (z = 40) is above its start.
  EXPECT_LT(frame.row(40.0), frame.row(0.0));
  EXPECT_GT(frame.column(20.0), frame.column(0.0));
  // The longer side (the 40 m of z, plus margins) is the plot side.
  EXPECT_EQ(std::max(frame.plot_width, frame.plot_height), 600);
  EXPECT_EQ(at(image, frame.column(0.0), frame.row(20.0)), of(top_view_colours::kEstimate));
  EXPECT_EQ(at(image, frame.column(10.0), frame.row(40.0)), of(top_view_colours::kEstimate));
  EXPECT_EQ(at(image, frame.column(0.0), frame.row(0.0)), of(top_view_colours::kStart));
  EXPECT_EQ(at(image, frame.column(20.0), frame.row(40.0)), of(top_view_colours::kEnd));
  // A wall point is grey; open ground is white.
  const Pixel wall = at(image, std::floor(frame.column(-5.0)), std::floor(frame.row(20.0)));
  EXPECT_EQ(wall[0], wall[1]);
  EXPECT_LT(wall[0], 235);
  EXPECT_EQ(at(image, frame.column(15.0), frame.row(10.0)), (Pixel{255, 255, 255}));
}

TEST(TopView, GroundTruthIsDrawnWiderUnderTheEstimate) {
  TopViewInput input = l_shaped_drive();
  input.ground_truth = input.estimate;
  for (Eigen::Vector3d& p : input.ground_truth) p.x() += 0.5;  // beside the estimate
  TopViewFrame frame;
  const RgbImage image = draw_top_view(input, 600, &frame);
  EXPECT_EQ(at(image, frame.column(0.0), frame.row(20.0)), of(top_view_colours::kEstimate));
  EXPECT_EQ(at(image, frame.column(0.5) + 2.0, frame.row(20.0)), of(top_view_colours::kGroundTruth));
}

TEST(TopView, StrayMapPointsDoNotShrinkTheView) {
  TopViewInput input = l_shaped_drive();
  TopViewFrame tidy;
  draw_top_view(input, 600, &tidy);
  input.map_points.emplace_back(3000.0, 0.0, -5000.0);  // one wild point (< 1 % of them)
  TopViewFrame with_stray;
  draw_top_view(input, 600, &with_stray);
  EXPECT_DOUBLE_EQ(with_stray.pixels_per_m, tidy.pixels_per_m);
}

TEST(TopView, AnEmptyRunStillGivesAPicture) {
  const RgbImage image = draw_top_view(TopViewInput{}, 300);
  EXPECT_GT(image.width, 300);
  EXPECT_GT(image.height, 300);
  EXPECT_EQ(image.rgb.size(), static_cast<std::size_t>(image.width) * image.height * 3);
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_EVAL_BUILT
