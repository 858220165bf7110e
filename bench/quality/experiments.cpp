#include "quality/experiments.hpp"

#include "porta/frontend.hpp"
#include "quality/quality_data.hpp"

namespace porta::quality {

const char* detector_label(int detector) {
  switch (detector) {
    case kOursBounded:
      return "ours bounded (arc 9-13)";
    case kOursClassic:
      return "ours classic (arc 9-16)";
    case kOursNoPfa:
      return "ours bounded, PFA off";
    case kOpenCvFast:
      return "OpenCV FAST top-N";
    case kOpenCvOrb:
      return "OpenCV ORB";
    default:
      return "?";
  }
}

const char* diagnostic_label(int diagnostic) {
  switch (diagnostic) {
    case kOursOneLevel:
      return "ours 1 level, arc 9-16, PFA off";
    case kOpenCvFastPerCell:
      return "OpenCV FAST, best per cell";
    case kOpenCvFastSameCount:
      return "OpenCV FAST top-N, same count";
    default:
      return "?";
  }
}

namespace {

FrontendSettings without_pfa(FrontendSettings base) {
  base.max_arc = 13;
  base.pfa = false;
  return base;
}

FrontendSettings one_level_classic(FrontendSettings base) {
  base.levels = 1;
  base.max_arc = 16;
  base.pfa = false;
  return base;
}

}  // namespace

FrontendSettings with_max_arc(FrontendSettings base, int max_arc) {
  base.max_arc = max_arc;
  return base;
}

OxfordEvaluator::OxfordEvaluator(Backend& backend, const FrontendSettings& base, const OxfordParams& params)
    : base_(base),
      params_(params),
      bounded_(backend, with_max_arc(base, 13), /*describe=*/true),
      classic_(backend, with_max_arc(base, 16), /*describe=*/false),
      no_pfa_(backend, without_pfa(base), /*describe=*/true),
      one_level_(backend, one_level_classic(base), /*describe=*/false) {}

ImageFeatures OxfordEvaluator::features(const cv::Mat& gray) {
  ImageFeatures f;
  f.size = gray.size();
  f.sets[kOursBounded] = bounded_.detect(gray);
  const int n = f.sets[kOursBounded].size();
  f.sets[kOursClassic] = keep_strongest(classic_.detect(gray), n);
  f.sets[kOursNoPfa] = keep_strongest(no_pfa_.detect(gray), n);
  f.sets[kOpenCvFast] = opencv_fast(gray, params_.opencv_fast_threshold, n);
  f.sets[kOpenCvOrb] = opencv_orb(gray, n, base_.levels, base_.scale_factor, base_.fast_threshold);
  f.diagnostics[kOursOneLevel] = one_level_.detect(gray);
  f.diagnostics[kOpenCvFastPerCell] =
      opencv_fast_per_cell(gray, base_.fast_threshold, base_.cell_width, base_.edge);
  f.diagnostics[kOpenCvFastSameCount] =
      opencv_fast(gray, base_.fast_threshold, f.diagnostics[kOursOneLevel].size());
  return f;
}

OxfordPairResult OxfordEvaluator::compare(const std::string& set, int target, const ImageFeatures& first,
                                          const ImageFeatures& second, const cv::Matx33d& h) const {
  OxfordPairResult r;
  r.set = set;
  r.target = target;
  for (int d = 0; d < kOxfordDetectors; ++d) {
    const auto& a = first.sets[static_cast<std::size_t>(d)];
    const auto& b = second.sets[static_cast<std::size_t>(d)];
    r.count_first[static_cast<std::size_t>(d)] = a.size();
    r.count_second[static_cast<std::size_t>(d)] = b.size();
    r.repeatability[static_cast<std::size_t>(d)] =
        repeatability(a.points, first.size, b.points, second.size, h, params_.repeat_epsilon_px);
  }
  for (std::size_t d = 0; d < kCullingDiagnostics; ++d) {
    r.diagnostic_count_first[d] = first.diagnostics[d].size();
    r.diagnostic_repeatability[d] =
        repeatability(first.diagnostics[d].points, first.size, second.diagnostics[d].points, second.size, h,
                      params_.repeat_epsilon_px);
  }
  r.ours_matching = matching_score(first.sets[kOursBounded], first.size, second.sets[kOursBounded],
                                   second.size, h, params_.correct_match_px);
  r.ours_no_pfa_matching = matching_score(first.sets[kOursNoPfa], first.size, second.sets[kOursNoPfa],
                                          second.size, h, params_.correct_match_px);
  r.opencv_matching = matching_score(first.sets[kOpenCvOrb], first.size, second.sets[kOpenCvOrb], second.size,
                                     h, params_.correct_match_px);
  return r;
}

OxfordPairResult OxfordEvaluator::evaluate_pair(const std::filesystem::path& data_dir, const std::string& set,
                                                int target) {
  const ImageFeatures first = features(load_oxford_image(data_dir, set, 1));
  const ImageFeatures second = features(load_oxford_image(data_dir, set, target));
  return compare(set, target, first, second, load_oxford_homography(data_dir, set, target));
}

FrontendSettings middlebury_settings(FrontendSettings base, int max_disparity) {
  base.stereo_min_disparity = 0;
  base.stereo_max_disparity = max_disparity;
  return base;
}

StereoSceneResult evaluate_stereo_scene(Backend& backend, const FrontendSettings& settings,
                                        const std::filesystem::path& data_dir, const std::string& scene) {
  const StereoScene s = load_middlebury_scene(data_dir, scene);
  StereoSceneResult r;
  r.scene = scene;
  r.size = s.left.size();
  cv::minMaxLoc(s.true_disparity, nullptr, &r.max_true_disparity_px);
  Frontend frontend(backend, settings, s.left.cols, s.left.rows);
  const StereoFeatures stereo = frontend.detect_stereo(view_of(s.left), view_of(s.right));
  r.accuracy = stereo_accuracy(stereo, frontend.tables(), s.true_disparity);
  return r;
}

}  // namespace porta::quality
