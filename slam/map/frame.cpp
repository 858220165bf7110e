#include "porta/slam/frame.hpp"

#include <algorithm>
#include <cmath>

#include "porta/tables.hpp"

namespace porta::slam {

ScalePyramid::ScalePyramid(int levels_in, double scale_factor_in) : levels(levels_in), scale_factor(scale_factor_in) {
  scale.resize(levels);
  sigma2.resize(levels);
  inv_sigma2.resize(levels);
  for (int n = 0; n < levels; ++n) {
    scale[n] = std::pow(scale_factor, n);
    sigma2[n] = scale[n] * scale[n];
    inv_sigma2[n] = 1.0 / sigma2[n];
  }
}

FrameFeatures FrameFeatures::from_frontend(const StereoFeatures& stereo, const FrontendTables& tables,
                                           const StereoCamera& camera, double min_disparity_px) {
  const Features& left = stereo.left;
  const std::size_t n = left.keypoints.size();
  FrameFeatures out;
  out.uv.resize(n);
  out.level.resize(n);
  out.angle_rad.resize(n);
  out.u_right.assign(n, -1.0f);
  out.depth_m.assign(n, -1.0f);
  out.descriptors = left.descriptors;
  out.keypoints = left.keypoints;
  out.descriptors.resize(n);
  const int bins = tables.settings.orientation_bins;
  for (std::size_t i = 0; i < n; ++i) {
    const Keypoint& kp = left.keypoints[i];
    out.uv[i] = Eigen::Vector2f(static_cast<float>(left.level0_x(i, tables)),
                                static_cast<float>(left.level0_y(i, tables)));
    out.level[i] = kp.level;
    out.angle_rad[i] = static_cast<float>(orientation_bin_center_rad(kp.angle_bin, bins));
    if (i < stereo.matches.size() && stereo.matches[i].disparity_q8 >= 0) {
      const double disparity = stereo.matches[i].disparity_q8 / 256.0;
      if (disparity >= min_disparity_px && disparity > 0.0) {
        out.u_right[i] = static_cast<float>(out.uv[i].x() - disparity);
        out.depth_m[i] = static_cast<float>(camera.bf() / disparity);
      }
    }
  }
  return out;
}

FeatureGrid::FeatureGrid(const FrameFeatures& features, int width, int height, int cell_px)
    : cols_(std::max(1, (width + cell_px - 1) / cell_px)),
      rows_(std::max(1, (height + cell_px - 1) / cell_px)),
      cell_px_(cell_px),
      cell_begin_(static_cast<std::size_t>(cols_) * rows_ + 1, 0),
      indices_(features.size()) {
  // Counting sort by cell: each cell's indices stay ascending, as the features come.
  std::vector<int> cell_of(features.size());
  for (std::size_t i = 0; i < features.size(); ++i) {
    const int cx = std::clamp(static_cast<int>(features.uv[i].x() / cell_px_), 0, cols_ - 1);
    const int cy = std::clamp(static_cast<int>(features.uv[i].y() / cell_px_), 0, rows_ - 1);
    cell_of[i] = cy * cols_ + cx;
    ++cell_begin_[static_cast<std::size_t>(cell_of[i]) + 1];
  }
  for (std::size_t c = 1; c < cell_begin_.size(); ++c) cell_begin_[c] += cell_begin_[c - 1];
  std::vector<int> next(cell_begin_.begin(), cell_begin_.end() - 1);
  for (std::size_t i = 0; i < features.size(); ++i) {
    indices_[static_cast<std::size_t>(next[static_cast<std::size_t>(cell_of[i])]++)] = static_cast<int>(i);
  }
}

std::vector<int> FeatureGrid::in_area(const FrameFeatures& features, float u, float v, float radius,
                                      int min_level, int max_level) const {
  std::vector<int> found;
  in_area(features, u, v, radius, min_level, max_level, found);
  return found;
}

void FeatureGrid::in_area(const FrameFeatures& features, float u, float v, float radius, int min_level,
                          int max_level, std::vector<int>& found) const {
  found.clear();
  if (indices_.empty() || !(radius >= 0.0f) || !std::isfinite(u) || !std::isfinite(v)) return;
  const int x0 = std::max(0, static_cast<int>(std::floor((u - radius) / cell_px_)));
  const int x1 = std::min(cols_ - 1, static_cast<int>(std::floor((u + radius) / cell_px_)));
  const int y0 = std::max(0, static_cast<int>(std::floor((v - radius) / cell_px_)));
  const int y1 = std::min(rows_ - 1, static_cast<int>(std::floor((v + radius) / cell_px_)));
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      const std::size_t cell = static_cast<std::size_t>(cy) * cols_ + cx;
      for (int k = cell_begin_[cell]; k < cell_begin_[cell + 1]; ++k) {
        const int i = indices_[static_cast<std::size_t>(k)];
        const int level = features.level[i];
        if (level < min_level || (max_level >= 0 && level > max_level)) continue;
        if (std::abs(features.uv[i].x() - u) <= radius && std::abs(features.uv[i].y() - v) <= radius) {
          found.push_back(i);
        }
      }
    }
  }
  // One cell's indices are ascending already; several cells' are merged by the sort.
  if (x0 != x1 || y0 != y1) std::sort(found.begin(), found.end());
}

Frame::Frame(std::uint64_t id_in, double time_in, std::shared_ptr<const FrameFeatures> features_in,
             const StereoCamera& camera)
    : id(id_in),
      time_s(time_in),
      features(std::move(features_in)),
      grid(*features, camera.width, camera.height),
      points(features->size(), nullptr),
      outlier(features->size(), false) {}

Eigen::Vector3d Frame::unproject_stereo(std::size_t i, const StereoCamera& camera) const {
  const double z = features->depth_m[i];
  const Eigen::Vector3d in_camera((features->uv[i].x() - camera.cx) * z / camera.fx,
                                  (features->uv[i].y() - camera.cy) * z / camera.fy, z);
  return T_cw.inverse() * in_camera;
}

}  // namespace porta::slam
