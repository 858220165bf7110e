// The picture `portaslam features` writes in a build without OpenCV: no circles, text or match
// lines, just the image (a pair side by side) with a small cross at every keypoint, coloured by
// its pyramid level as in the OpenCV picture.
#pragma once

#include <cstdint>
#include <vector>

#include "porta/frontend.hpp"
#include "porta/image.hpp"

namespace porta::app {

struct RgbPicture {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  ///< packed rows of width * 3 bytes
};

/// The image with its keypoints.
RgbPicture plain_features(const Image& image, const Features& features, const FrontendTables& tables);
/// left | right, each with its keypoints.
RgbPicture plain_stereo(const Image& left, const Image& right, const StereoFeatures& stereo,
                        const FrontendTables& tables);

}  // namespace porta::app
