#include "quality/detectors.hpp"

#include <algorithm>
#include <numeric>
#include <opencv2/features2d.hpp>
#include <stdexcept>

namespace porta::quality {

ImageView view_of(const cv::Mat& gray) {
  if (gray.type() != CV_8UC1) throw std::invalid_argument("view_of: expected an 8-bit single-channel image");
  return {gray.data, gray.cols, gray.rows, static_cast<int>(gray.step[0])};
}

PortaDetector::PortaDetector(Backend& backend, const FrontendSettings& settings, bool describe)
    : backend_(backend), settings_(settings), describe_(describe) {
  settings_.validate();
}

Frontend& PortaDetector::frontend(int width, int height) {
  auto& slot = frontends_[{width, height}];
  if (!slot) {
    FrontendOptions options;
    options.describe = describe_;
    slot = std::make_unique<Frontend>(backend_, settings_, width, height, options);
  }
  return *slot;
}

FeatureSet to_feature_set(const Features& features, const FrontendTables& tables) {
  FeatureSet out;
  const std::size_t n = features.keypoints.size();
  out.points.reserve(n);
  out.responses.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    out.points.emplace_back(features.level0_x(i, tables), features.level0_y(i, tables));
    out.responses.push_back(features.keypoints[i].response);
  }
  if (!features.descriptors.empty()) {
    out.descriptors.create(static_cast<int>(n), static_cast<int>(sizeof(Descriptor)), CV_8U);
    for (std::size_t i = 0; i < n; ++i)
      std::copy(features.descriptors[i].bytes.begin(), features.descriptors[i].bytes.end(),
                out.descriptors.ptr<std::uint8_t>(static_cast<int>(i)));
  }
  return out;
}

FeatureSet PortaDetector::detect(const cv::Mat& gray) {
  Frontend& f = frontend(gray.cols, gray.rows);
  return to_feature_set(f.detect(view_of(gray)), f.tables());
}

FeatureSet keep_strongest(const FeatureSet& features, int count) {
  if (count >= features.size()) return features;
  std::vector<int> order(static_cast<std::size_t>(features.size()));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return features.responses[a] > features.responses[b]; });
  order.resize(static_cast<std::size_t>(std::max(count, 0)));
  std::sort(order.begin(), order.end());  // keep the detector's own order
  FeatureSet out;
  for (int i : order) {
    out.points.push_back(features.points[i]);
    out.responses.push_back(features.responses[i]);
  }
  if (!features.descriptors.empty()) {
    out.descriptors.create(static_cast<int>(order.size()), features.descriptors.cols, CV_8U);
    for (std::size_t k = 0; k < order.size(); ++k)
      features.descriptors.row(order[k]).copyTo(out.descriptors.row(static_cast<int>(k)));
  }
  return out;
}

namespace {

FeatureSet from_opencv(const std::vector<cv::KeyPoint>& keypoints, const cv::Mat& descriptors) {
  FeatureSet out;
  for (const auto& k : keypoints) {
    out.points.emplace_back(k.pt.x, k.pt.y);
    out.responses.push_back(k.response);
  }
  out.descriptors = descriptors;
  return out;
}

}  // namespace

FeatureSet opencv_fast(const cv::Mat& gray, int threshold, int count) {
  auto fast = cv::FastFeatureDetector::create(threshold, true, cv::FastFeatureDetector::TYPE_9_16);
  std::vector<cv::KeyPoint> keypoints;
  fast->detect(gray, keypoints);
  return keep_strongest(from_opencv(keypoints, {}), count);
}

FeatureSet opencv_fast_per_cell(const cv::Mat& gray, int threshold, int cell, int edge) {
  auto fast = cv::FastFeatureDetector::create(threshold, true, cv::FastFeatureDetector::TYPE_9_16);
  std::vector<cv::KeyPoint> keypoints;
  fast->detect(gray, keypoints);
  const int cols = (gray.cols + cell - 1) / cell, rows = (gray.rows + cell - 1) / cell;
  std::vector<int> best(static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows), -1);
  for (int i = 0; i < static_cast<int>(keypoints.size()); ++i) {
    const auto& k = keypoints[static_cast<std::size_t>(i)];
    const int x = static_cast<int>(k.pt.x), y = static_cast<int>(k.pt.y);
    if (x < edge || y < edge || x >= gray.cols - edge || y >= gray.rows - edge) continue;
    int& slot = best[static_cast<std::size_t>(y / cell) * static_cast<std::size_t>(cols) +
                     static_cast<std::size_t>(x / cell)];
    if (slot < 0 || k.response > keypoints[static_cast<std::size_t>(slot)].response) slot = i;
  }
  std::vector<cv::KeyPoint> kept;
  for (int i : best)
    if (i >= 0) kept.push_back(keypoints[static_cast<std::size_t>(i)]);
  return from_opencv(kept, {});
}

FeatureSet opencv_orb(const cv::Mat& gray, int count, int levels, double scale_factor, int fast_threshold) {
  auto orb = cv::ORB::create(std::max(count, 1), static_cast<float>(scale_factor), levels, 31, 0, 2,
                             cv::ORB::HARRIS_SCORE, 31, fast_threshold);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  orb->detectAndCompute(gray, cv::noArray(), keypoints, descriptors);
  return from_opencv(keypoints, descriptors);
}

}  // namespace porta::quality
