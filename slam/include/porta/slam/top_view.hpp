// The top view of a run (`portaslam run` writes it as <out>/map_top.png): the map points seen from
// above as grey dots (darker where more points fall on one pixel), the estimated trajectory and,
// when there is ground truth, the ground-truth trajectory, on the x-z plane of the map's world frame
// (the first camera's: x to the right, z forward, which is up in the picture; y points down, into
// the picture). Drawn by hand into an RGB buffer (no OpenCV), with a caption, a legend and a scale
// bar in a 5x7 pixel font.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace porta::slam {

struct TopViewInput {
  std::vector<Eigen::Vector3d> map_points;
  std::vector<Eigen::Vector3d> estimate;      ///< camera centres in time order
  std::vector<Eigen::Vector3d> ground_truth;  ///< camera centres in the map's frame (aligned); empty: none
  std::string title;                          ///< the caption's first line, e.g. the dataset
  std::string ground_truth_label = "ground truth";
};

struct RgbImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< packed rows of width * 3 bytes
  const std::uint8_t* pixel(int x, int y) const {
    return &rgb[(static_cast<std::size_t>(y) * width + x) * 3];
  }
};

/// Colours of the top view ({red, green, blue}).
namespace top_view_colours {
inline constexpr std::uint8_t kEstimate[3] = {20, 90, 220};     ///< blue
inline constexpr std::uint8_t kGroundTruth[3] = {255, 140, 0};  ///< orange
inline constexpr std::uint8_t kStart[3] = {0, 160, 60};         ///< green dot
inline constexpr std::uint8_t kEnd[3] = {200, 0, 0};            ///< red dot (the estimate's last pose)
}  // namespace top_view_colours

/// How the view maps the world's x-z plane to pixels: column = x0 + scale (x - min_x),
/// row = y0 + scale (max_z - z). Chosen to fit the trajectories whole and the map points between
/// their 1st and 99th percentiles (x and z apart; points beyond are clipped), with 4 % margins.
struct TopViewFrame {
  double min_x = 0.0, max_z = 0.0;
  double pixels_per_m = 1.0;
  int x0 = 0, y0 = 0;  ///< the plot's top-left pixel
  int plot_width = 0, plot_height = 0;
  double column(double x) const { return x0 + pixels_per_m * (x - min_x); }
  double row(double z) const { return y0 + pixels_per_m * (max_z - z); }
};

/// The picture; its longer plot side is `plot_side_px` pixels (the whole picture is a little larger:
/// margins, caption and legend). `frame` (optional) receives the mapping used.
RgbImage draw_top_view(const TopViewInput& input, int plot_side_px = 1000, TopViewFrame* frame = nullptr);

}  // namespace porta::slam
