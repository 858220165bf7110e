// The experiments of the quality report on real data, shared by the porta_quality program and
// the quality tests: Oxford pairs (repeatability, matching score) and Middlebury scenes (sparse
// stereo accuracy).
#pragma once

#include <array>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "porta/backend.hpp"
#include "porta/settings.hpp"
#include "quality/detectors.hpp"
#include "quality/metrics.hpp"

namespace porta::quality {

/// Thresholds of the Oxford measures, in level-0 pixels.
struct OxfordParams {
  double repeat_epsilon_px = 1.5;  ///< a keypoint repeats when its projection lies this close
  double correct_match_px = 3.0;   ///< a descriptor match is correct when this close
  int opencv_fast_threshold = 20;
};

/// The detectors compared on Oxford, in report order.
enum OxfordDetector { kOursBounded = 0, kOursClassic, kOursNoPfa, kOpenCvFast, kOpenCvOrb, kOxfordDetectors };
const char* detector_label(int detector);

/// Single-scale detectors that separate the effect of culling from that of the corner score:
/// ours with 1 level, classic FAST, PFA off (one keypoint per cell) against OpenCV FAST culled to
/// the same cells, and OpenCV FAST keeping as many strongest corners over the whole image.
enum CullingDiagnostic { kOursOneLevel = 0, kOpenCvFastPerCell, kOpenCvFastSameCount, kCullingDiagnostics };
const char* diagnostic_label(int diagnostic);

/// Every detector's features on one image. Counts are matched to ours-bounded's count N: classic
/// FAST and PFA-off keep their N strongest, OpenCV FAST its N strongest, OpenCV ORB is asked for N.
struct ImageFeatures {
  cv::Size size;
  std::array<FeatureSet, kOxfordDetectors> sets;
  std::array<FeatureSet, kCullingDiagnostics> diagnostics;
};

struct OxfordPairResult {
  std::string set;
  int target = 0;  ///< imgN
  std::array<Repeatability, kOxfordDetectors> repeatability{};
  std::array<int, kOxfordDetectors> count_first{};   ///< keypoints on img1
  std::array<int, kOxfordDetectors> count_second{};  ///< on imgN
  std::array<Repeatability, kCullingDiagnostics> diagnostic_repeatability{};
  std::array<int, kCullingDiagnostics> diagnostic_count_first{};
  MatchingScore ours_matching;         ///< ours-bounded ORB descriptors
  MatchingScore ours_no_pfa_matching;  ///< the same with PFA off
  MatchingScore opencv_matching;       ///< cv::ORB
};

/// `base` with bounded rectification (max_arc 13) or classic FAST (max_arc 16).
FrontendSettings with_max_arc(FrontendSettings base, int max_arc);

class OxfordEvaluator {
 public:
  /// Ours-bounded uses `base` with max_arc 13 (described); ours-classic max_arc 16 (detection
  /// only); ours-PFA-off max_arc 13 and PFA off (described); OpenCV ORB uses base's levels, scale
  /// factor and FAST threshold.
  OxfordEvaluator(Backend& backend, const FrontendSettings& base, const OxfordParams& params = {});

  ImageFeatures features(const cv::Mat& gray);
  OxfordPairResult compare(const std::string& set, int target, const ImageFeatures& first,
                           const ImageFeatures& second, const cv::Matx33d& h) const;
  /// Loads img1, img`target` and H1to`target`p of `set` and compares them.
  OxfordPairResult evaluate_pair(const std::filesystem::path& data_dir, const std::string& set, int target);

  const FrontendSettings& bounded_settings() const { return bounded_.settings(); }
  const OxfordParams& params() const { return params_; }

 private:
  FrontendSettings base_;
  OxfordParams params_;
  PortaDetector bounded_;
  PortaDetector classic_;
  PortaDetector no_pfa_;
  PortaDetector one_level_;
};

/// Stereo settings for Middlebury 2001/2003: `base` with the disparity search 0..max_disparity.
FrontendSettings middlebury_settings(FrontendSettings base, int max_disparity);

struct StereoSceneResult {
  std::string scene;
  cv::Size size;
  double max_true_disparity_px = 0.0;
  StereoAccuracy accuracy;
};

/// Runs Frontend::detect_stereo on the scene's im2 (left) and im6 (right) and scores each match
/// against disp2.
StereoSceneResult evaluate_stereo_scene(Backend& backend, const FrontendSettings& settings,
                                        const std::filesystem::path& data_dir, const std::string& scene);

}  // namespace porta::quality
