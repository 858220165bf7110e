// Drawing the frontend's output for people: keypoints as circles whose radius follows the level's
// scale, coloured by level, with a tick along the orientation bin's centre angle; for a stereo pair
// also the matches (lines between the views and points coloured by disparity).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "porta/frontend.hpp"
#include "porta/image.hpp"

namespace porta::app {

/// The true disparity of each left pixel, when known (the built-in pair); used to mark wrong matches.
struct KnownDisparity {
  const std::vector<std::uint8_t>* disparity_px = nullptr;  ///< row-major, left image size
  int width = 0;
};

/// One image: the image with its keypoints, and a legend strip below it. BGR, 8-bit.
cv::Mat draw_features(const Image& image, const Features& features, const FrontendTables& tables);

/// A pair, as a 2x2 mosaic: left | right with keypoints and a sample of match lines on top; below,
/// the left image with every matched keypoint coloured by disparity (wrong ones crossed in red
/// when `known` is given) next to a legend panel. BGR, 8-bit.
cv::Mat draw_stereo(const Image& left, const Image& right, const StereoFeatures& stereo,
                    const FrontendTables& tables, const KnownDisparity& known = {});

}  // namespace porta::app
