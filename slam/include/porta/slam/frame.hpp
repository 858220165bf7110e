// A stereo frame as the SLAM back end sees it (DESIGN.md §6): the frontend's keypoints moved to
// level-0 rectified pixel coordinates, their descriptors, stereo depth, and a grid for finding the
// features near a pixel. Keyframes share a frame's features (immutable once built).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "porta/frontend.hpp"
#include "porta/keypoint.hpp"
#include "porta/slam/pose.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam {

/// Per-level scale of the image pyramid, as ORB-SLAM2 uses it: a keypoint at level n was found in
/// an image scaled by 1/s^n, so its position is uncertain by sigma = s^n pixels at level 0.
struct ScalePyramid {
  int levels = 8;
  double scale_factor = 1.2;
  std::vector<double> scale;      ///< s^n
  std::vector<double> sigma2;     ///< s^(2n): variance of a level-n observation in level-0 px^2
  std::vector<double> inv_sigma2;

  ScalePyramid() = default;
  ScalePyramid(int levels, double scale_factor);
};

/// Every feature of one stereo frame, struct-of-arrays, index = the frontend's keypoint order.
struct FrameFeatures {
  std::vector<Eigen::Vector2f> uv;          ///< level-0 rectified pixel position (left image)
  std::vector<std::uint8_t> level;          ///< pyramid level the keypoint was found at
  std::vector<float> angle_rad;             ///< orientation, [0, 2pi)
  std::vector<Descriptor> descriptors;
  std::vector<float> u_right;               ///< right-image column of the stereo match, < 0: none
  std::vector<float> depth_m;               ///< bf / disparity, < 0: no stereo match
  /// The frontend's keypoints (level-n integer position, level, angle bin), one per feature, as the
  /// projection-match kernel reads them (DESIGN.md §3.10). Empty when the features were not made by
  /// from_frontend (tests, loaded maps): tracking then derives them from `uv` and `level`.
  std::vector<Keypoint> keypoints;

  std::size_t size() const { return uv.size(); }
  bool has_depth(std::size_t i) const { return depth_m[i] > 0.0f; }

  /// Converts the frontend's output for a rectified pair. Matches with a disparity below
  /// `min_disparity_px` (too far to give depth) are dropped.
  static FrameFeatures from_frontend(const StereoFeatures& features, const FrontendTables& tables,
                                     const StereoCamera& camera, double min_disparity_px = 0.5);
};

/// Buckets feature indices by level-0 position for radius queries (ORB-SLAM2's frame grid).
class FeatureGrid {
 public:
  FeatureGrid() = default;
  FeatureGrid(const FrameFeatures& features, int width, int height, int cell_px = 16);

  /// Indices of the features within the square window |u-x| <= radius, |v-y| <= radius whose
  /// level is in [min_level, max_level] (max_level < 0: no upper bound), in ascending index order.
  std::vector<int> in_area(const FrameFeatures& features, float u, float v, float radius, int min_level = 0,
                           int max_level = -1) const;
  /// The same into `found` (cleared first): loops that query per point reuse one buffer.
  void in_area(const FrameFeatures& features, float u, float v, float radius, int min_level, int max_level,
               std::vector<int>& found) const;

 private:
  int cols_ = 0, rows_ = 0, cell_px_ = 16;
  std::vector<int> cell_begin_;  ///< cell c's features are indices_[cell_begin_[c], cell_begin_[c + 1])
  std::vector<int> indices_;     ///< feature indices by cell, ascending within a cell
};

class MapPoint;
class KeyFrame;

/// One tracked stereo frame. Owned by the tracker; keyframes are made from it.
struct Frame {
  std::uint64_t id = 0;
  double time_s = 0.0;
  std::shared_ptr<const FrameFeatures> features;
  FeatureGrid grid;
  SE3 T_cw = SE3::Identity();  ///< world -> camera (the optimiser's convention)
  bool has_pose = false;
  std::vector<MapPoint*> points;  ///< per feature: the map point it observes, or nullptr
  std::vector<bool> outlier;      ///< per feature: rejected by the last pose optimisation
  KeyFrame* reference_keyframe = nullptr;

  Frame() = default;
  Frame(std::uint64_t id, double time_s, std::shared_ptr<const FrameFeatures> features, const StereoCamera& camera);

  /// Camera centre in the world.
  Eigen::Vector3d center() const { return T_cw.inverse().translation(); }
  /// The feature's 3-D position in the world from its stereo depth (requires has_depth(i)).
  Eigen::Vector3d unproject_stereo(std::size_t i, const StereoCamera& camera) const;
};

}  // namespace porta::slam
