// ORB-SLAM2-style YAML settings files (DESIGN.md §6): users bring the file they ran ORB-SLAM2 with
// (e.g. ORB-SLAM2's KITTI00-02.yaml or EuRoC.yaml; ours are in settings/). The file is OpenCV
// FileStorage YAML ("%YAML:1.0" first line; added when absent) with flat keys such as
// "Camera.fx". Every key is optional here; what a key is needed for is checked where it is used.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/settings.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam {

/// A settings file that is missing, not YAML, or has a key of the wrong type or a bad value.
/// what() names the file and the key.
class SettingsFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One camera's stereo rectification as ORB-SLAM2 stores it (LEFT.* / RIGHT.*): the raw camera K
/// and distortion D (k1 k2 p1 p2 [k3]), the rectifying rotation R (x_rect = R * x_raw) and the
/// rectified projection P (3x4). height/width are the raw (and rectified) image size.
struct RectificationSide {
  std::optional<int> height, width;
  std::optional<Eigen::Matrix3d> K;
  std::optional<std::vector<double>> D;
  std::optional<Eigen::Matrix3d> R;
  std::optional<Eigen::Matrix<double, 3, 4>> P;

  bool any() const { return height || width || K || D || R || P; }
  bool complete() const { return height && width && K && D && R && P; }
};

struct SettingsFile {
  std::string path;  ///< the file read (for messages)

  // Camera.*: the rectified camera (ORB-SLAM2 stereo).
  std::optional<double> fx, fy, cx, cy;
  std::optional<double> k1, k2, p1, p2, k3;
  std::optional<int> width, height;
  std::optional<double> fps;
  std::optional<double> bf;        ///< Camera.bf: baseline (m) times fx
  std::optional<bool> rgb;         ///< Camera.RGB: 1 = RGB order, 0 = BGR (ignored for gray images)
  std::optional<double> th_depth;  ///< ThDepth: close/far threshold in baselines

  // ORBextractor.*
  std::optional<int> orb_features;         ///< nFeatures (informational: we cull by cells)
  std::optional<double> orb_scale_factor;  ///< scaleFactor
  std::optional<int> orb_levels;           ///< nLevels
  std::optional<int> orb_ini_th_fast;      ///< iniThFAST
  std::optional<int> orb_min_th_fast;      ///< minThFAST (informational)

  RectificationSide left, right;  ///< LEFT.*, RIGHT.*

  /// Both LEFT.* and RIGHT.* are complete (height, width, K, D, R, P).
  bool has_rectification() const { return left.complete() && right.complete(); }
  /// Throws SettingsFileError naming the first missing LEFT./RIGHT. key when the block is partial.
  void check_rectification_complete() const;

  /// The rectified stereo camera: needs Camera.fx, fy, cx, cy, bf, width, height (the error names
  /// the first missing key); baseline = bf / fx. Validated (SettingsFileError names the file).
  StereoCamera stereo_camera() const;
  /// Nonzero Camera.k1/k2/p1/p2/k3 (ORB-SLAM2 then undistorts keypoints).
  bool has_distortion() const;

  /// Maps ORBextractor.nLevels -> levels, scaleFactor -> scale_factor, iniThFAST -> fast_threshold
  /// (keys absent from the file leave the field as it is). Throws SettingsFileError naming the key
  /// and the allowed range on a bad value; `settings` is left unchanged then.
  void apply_to(FrontendSettings& settings) const;
};

/// Reads a settings file. Throws SettingsFileError when the file is missing or unreadable, is not
/// YAML, or a known key has the wrong type (e.g. a string for Camera.fx, 2.5 for Camera.width, a
/// LEFT.K that is not a 3x3 matrix). Unknown keys are ignored (ORB-SLAM2 files carry viewer keys).
SettingsFile read_settings_file(const std::string& path);

}  // namespace porta::slam
