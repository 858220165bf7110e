#include "plain_picture.hpp"

#include <cmath>

#include "level_colours.hpp"

namespace porta::app {

namespace {

constexpr int kArm = 3;  // a cross is 2 * kArm + 1 px wide and high

// Copies `image` as gray RGB into columns [x0, x0 + width) of the picture.
void paste(RgbPicture& picture, const Image& image, int x0) {
  for (int y = 0; y < image.height(); ++y)
    for (int x = 0; x < image.width(); ++x) {
      std::uint8_t* p = &picture.rgb[(static_cast<std::size_t>(y) * picture.width + x0 + x) * 3];
      p[0] = p[1] = p[2] = image.at(x, y);
    }
}

void put(RgbPicture& picture, int x, int y, const std::array<std::uint8_t, 3>& bgr) {
  if (x < 0 || y < 0 || x >= picture.width || y >= picture.height) return;
  std::uint8_t* p = &picture.rgb[(static_cast<std::size_t>(y) * picture.width + x) * 3];
  p[0] = bgr[2];
  p[1] = bgr[1];
  p[2] = bgr[0];
}

// Crosses at every keypoint's level-0 position, shifted right by x0.
void mark(RgbPicture& picture, const Features& features, const FrontendTables& tables, int x0) {
  for (std::size_t i = 0; i < features.keypoints.size(); ++i) {
    const auto& colour = kLevelColoursBgr[features.keypoints[i].level % kLevelColoursBgr.size()];
    const int x = x0 + static_cast<int>(std::lround(features.level0_x(i, tables)));
    const int y = static_cast<int>(std::lround(features.level0_y(i, tables)));
    for (int d = -kArm; d <= kArm; ++d) {
      put(picture, x + d, y, colour);
      put(picture, x, y + d, colour);
    }
  }
}

RgbPicture blank(int width, int height) {
  return {width, height, std::vector<std::uint8_t>(static_cast<std::size_t>(width) * height * 3)};
}

}  // namespace

RgbPicture plain_features(const Image& image, const Features& features, const FrontendTables& tables) {
  RgbPicture picture = blank(image.width(), image.height());
  paste(picture, image, 0);
  mark(picture, features, tables, 0);
  return picture;
}

RgbPicture plain_stereo(const Image& left, const Image& right, const StereoFeatures& stereo,
                        const FrontendTables& tables) {
  RgbPicture picture = blank(left.width() + right.width(), left.height());
  paste(picture, left, 0);
  paste(picture, right, left.width());
  mark(picture, stereo.left, tables, 0);
  mark(picture, stereo.right, tables, left.width());
  return picture;
}

}  // namespace porta::app
