// Loading the real third-party quality data (../shared/data, see its README.md): where it lives,
// its images, the Oxford homographies and the Middlebury ground-truth disparities.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace porta::quality {

/// Raised when a data file is missing or malformed; the message names the file.
class DataError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The data folder: `cli_value` when not empty, else $PORTA_DATA_DIR when set, else the
/// build-time default ../shared/data beside the source tree.
std::filesystem::path resolve_data_dir(const std::string& cli_value);
/// The build-time default (../shared/data relative to the repository root).
std::filesystem::path default_data_dir();

/// 8-bit grayscale image (converted when stored in colour); throws DataError when unreadable.
cv::Mat load_gray(const std::filesystem::path& path);

/// The first matrix node of an OpenCV FileStorage file (the Oxford H1toNp.xml files name their
/// node H12, H13, ...), as a 3x3 double homography scaled to h33 = 1. Throws DataError when
/// there is none.
cv::Matx33d load_homography(const std::filesystem::path& path);

/// The Oxford homography img1 -> img`n` of `set` (n in 2..6).
cv::Matx33d load_oxford_homography(const std::filesystem::path& data_dir, const std::string& set, int n);
/// Oxford image img`n` of `set`.
cv::Mat load_oxford_image(const std::filesystem::path& data_dir, const std::string& set, int n);

/// The disparity scale of a Middlebury scene from middlebury/scales.xml (its lines read
/// `name "scale" "unknown value"`). Throws DataError when the scene is not listed.
int load_middlebury_scale(const std::filesystem::path& data_dir, const std::string& scene);

/// A Middlebury scene: left (im2), right (im6) and the true disparity of the left image in
/// pixels (disp2.png / scale; 0 = unknown).
struct StereoScene {
  std::string name;
  cv::Mat left;
  cv::Mat right;
  cv::Mat true_disparity;  ///< CV_32F, 0 = unknown
  int scale = 0;
};
StereoScene load_middlebury_scene(const std::filesystem::path& data_dir, const std::string& scene);

/// The sets and scenes of ../shared/data used by the quality report.
const std::vector<std::string>& oxford_sets();
const std::vector<std::string>& middlebury_scenes();

}  // namespace porta::quality
