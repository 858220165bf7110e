// The quality measures of the report, as plain functions of keypoint positions, descriptors and
// ground truth (homographies, true disparities), independent of which detector made them.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "porta/frontend.hpp"
#include "quality/detectors.hpp"

namespace porta::quality {

/// H applied to p (homogeneous division). Returns false when p maps to or behind infinity.
bool project(const cv::Matx33d& h, const cv::Point2d& p, cv::Point2d& out);
/// Inside the pixel area [0, width - 1] x [0, height - 1].
bool inside(const cv::Point2d& p, cv::Size size);

/// Indices of the keypoints in the region both images see: those of the first image whose
/// projection by H lies inside the second, and those of the second whose back-projection by H^-1
/// lies inside the first.
struct CommonRegion {
  std::vector<int> first;
  std::vector<int> second;
};
CommonRegion common_region(const std::vector<cv::Point2d>& first, cv::Size first_size,
                           const std::vector<cv::Point2d>& second, cv::Size second_size,
                           const cv::Matx33d& h);

/// Repeatability after Mikolajczyk et al.: keypoints of the common region are put in one-to-one
/// correspondence (closest pairs first) when the projection of the first lies within
/// `epsilon_px` of the second; repeatability = correspondences / min(common first, common second).
/// The symmetric variant also requires the back-projection of the second within `epsilon_px` of
/// the first: under strong zoom, epsilon in the zoomed-out image alone spans several pixels of the
/// other and lets nearby points repeat by chance.
struct Repeatability {
  int common_first = 0;
  int common_second = 0;
  int repeated = 0;
  double value = 0.0;  ///< 0 when either common count is 0
  int repeated_symmetric = 0;
  double symmetric_value = 0.0;
};
Repeatability repeatability(const std::vector<cv::Point2d>& first, cv::Size first_size,
                            const std::vector<cv::Point2d>& second, cv::Size second_size,
                            const cv::Matx33d& h, double epsilon_px);

/// Descriptor matching of the common-region keypoints by brute-force Hamming distance with cross
/// check (mutual nearest neighbours; ties go to the lower index). A match is correct when the
/// projection of its first keypoint lies within `correct_px` of its second keypoint.
/// score = correct / common first; precision = correct / mutual matches.
struct MatchingScore {
  int common_first = 0;
  int common_second = 0;
  int mutual_matches = 0;
  int correct_matches = 0;
  double score = 0.0;
  double precision = 0.0;
};
MatchingScore matching_score(const FeatureSet& first, cv::Size first_size, const FeatureSet& second,
                             cv::Size second_size, const cv::Matx33d& h, double correct_px);

/// Mutual nearest neighbours by Hamming distance between the rows of two CV_8U descriptor
/// matrices of equal width, restricted to the listed rows: pairs (first row, second row).
std::vector<std::pair<int, int>> mutual_hamming_matches(const cv::Mat& first,
                                                        const std::vector<int>& first_rows,
                                                        const cv::Mat& second,
                                                        const std::vector<int>& second_rows);

/// Sparse stereo accuracy against a true left disparity map (CV_32F px, 0 = unknown), read at
/// each matched left keypoint's level-0 position rounded to the nearest pixel.
struct StereoAccuracy {
  int left_keypoints = 0;
  int right_keypoints = 0;
  int matches = 0;
  int evaluated = 0;  ///< matches whose pixel has a known true disparity
  int within_1px = 0;
  int within_half_px = 0;
  double density = 0.0;              ///< matches / left keypoints
  double fraction_within_1px = 0.0;  ///< of evaluated
  double fraction_within_half_px = 0.0;
  double median_abs_error_px = 0.0;
  int fractional_disparities = 0;  ///< matches whose disparity is not a whole pixel (sub-pixel refined)
  /// The scored matches split by the left keypoint's pyramid level.
  std::vector<int> evaluated_by_level;
  std::vector<int> within_1px_by_level;
  std::vector<int> within_half_px_by_level;
};
StereoAccuracy stereo_accuracy(const StereoFeatures& stereo, const FrontendTables& tables,
                               const cv::Mat& true_disparity);

}  // namespace porta::quality
