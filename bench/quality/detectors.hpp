// The detectors compared by the quality report, all returning one FeatureSet: PortaSLAM's
// frontend on any backend, and OpenCV's FAST and ORB as outside references.
#pragma once

#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "porta/backend.hpp"
#include "porta/frontend.hpp"
#include "porta/settings.hpp"

namespace porta::quality {

/// Keypoints at level-0 pixel positions, their detector response (only compared within one
/// detector) and, when described, one 32-byte binary descriptor per row of `descriptors`.
struct FeatureSet {
  std::vector<cv::Point2d> points;
  std::vector<double> responses;
  cv::Mat descriptors;  ///< CV_8U, points.size() x 32, or empty
  int size() const { return static_cast<int>(points.size()); }
};

/// PortaSLAM's frontend with fixed settings on one backend; keeps one Frontend per image size.
class PortaDetector {
 public:
  PortaDetector(Backend& backend, const FrontendSettings& settings, bool describe);

  /// Keypoints at their level-0 positions (Features::level0_x/y), with descriptors if describing.
  FeatureSet detect(const cv::Mat& gray);
  /// The frontend for images of this size (built on first use).
  Frontend& frontend(int width, int height);

  const FrontendSettings& settings() const { return settings_; }

 private:
  Backend& backend_;
  FrontendSettings settings_;
  bool describe_;
  std::map<std::pair<int, int>, std::unique_ptr<Frontend>> frontends_;
};

/// The features of a PortaSLAM frontend call, as a FeatureSet (response = FAST score).
FeatureSet to_feature_set(const Features& features, const FrontendTables& tables);

/// A view of an 8-bit single-channel cv::Mat (no copy).
ImageView view_of(const cv::Mat& gray);

/// The `count` strongest features by response (ties keep the earlier one); all when fewer.
FeatureSet keep_strongest(const FeatureSet& features, int count);

/// OpenCV single-scale FAST-9/16 (cv::FastFeatureDetector, non-maximum suppression on) at
/// `threshold`, keeping the `count` strongest by response. No descriptors.
FeatureSet opencv_fast(const cv::Mat& gray, int threshold, int count);

/// OpenCV single-scale FAST-9/16 (non-maximum suppression on) at `threshold`, culled like our
/// level 0: the image is tiled from (0,0) into `cell` x `cell` cells and each keeps its strongest
/// corner; corners closer than `edge` to the border are dropped.
FeatureSet opencv_fast_per_cell(const cv::Mat& gray, int threshold, int cell, int edge);

/// OpenCV ORB (cv::ORB) asked for `count` features over `levels` levels of `scale_factor`,
/// FAST threshold `fast_threshold`, otherwise OpenCV's defaults (Harris score, patch 31, edge 31),
/// detected and described.
FeatureSet opencv_orb(const cv::Mat& gray, int count, int levels, double scale_factor, int fast_threshold);

}  // namespace porta::quality
