// Shared by the dataset readers (private to porta_dataset): messages, folder listings, image
// loading and stereo rectification (YAML files: yaml_reader.hpp).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "porta/image.hpp"
#include "porta/slam/dataset.hpp"
#include "porta/slam/pose.hpp"
#include "porta/slam/settings_file.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam::detail {

namespace fs = std::filesystem;

std::string in_quotes(const fs::path& path);
[[noreturn]] void fail(const std::string& message);

/// Throws DatasetError when `path` does not exist or is not a folder; `what` says what it should be.
void require_folder(const fs::path& path, const std::string& what);
bool is_folder(const fs::path& path);
bool is_file(const fs::path& path);

/// Names (not paths) of the image files in `folder` (png, jpg, jpeg, pgm, ppm, bmp, tif, tiff; any
/// case), sorted. Throws DatasetError when the folder is missing or has no image.
std::vector<std::string> list_image_names(const fs::path& folder, const std::string& what);
/// Throws DatasetError naming both folders and the first difference when the lists differ.
void require_same_names(const std::vector<std::string>& left, const fs::path& left_folder,
                        const std::vector<std::string>& right, const fs::path& right_folder);

/// times.txt: one time in seconds per line (blank lines skipped). Errors name the file and line.
std::vector<double> read_times_file(const fs::path& path);

/// Decodes an image file to 8-bit gray as `portaslam` does (16-bit / 255-per-65535, float scaled to
/// its range, color to gray with cvtColor's weights, gray+alpha keeps the gray). PNG through libpng
/// in every build; other formats through OpenCV where the build has it. Throws DatasetError naming
/// the file when it is missing, not decodable, or not `width` x `height` (when > 0).
Image read_gray(const fs::path& path, int width = 0, int height = 0);

/// Largest magnitude of a time stamp in seconds (~3000 years): more is a unit mistake or garbage.
inline constexpr double kMaxTimeS = 1e11;

/// Largest magnitude a lens distortion coefficient (k1 k2 p1 p2 k3) may have: real lenses,
/// fisheyes included, stay far below; beyond it the value is a typo and undistortion breaks down.
inline constexpr double kMaxDistortionCoefficient = 100.0;
/// "coefficient 1 (k1) is 1e+10, outside [-100, 100]" for the first coefficient out of range.
std::optional<std::string> distortion_problem(const std::vector<double>& coefficients);

/// Reads a ground-truth trajectory (format detected); TrajectoryError becomes DatasetError.
Trajectory read_ground_truth(const fs::path& path, const std::string& kitti_times_path = "");

/// Nearest rotation matrix (SVD); DatasetError naming `what` when `m` is far from a rotation.
Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& m, const std::string& what);

/// Raw pinhole camera with radial-tangential distortion.
struct RawCamera {
  int width = 0, height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  std::vector<double> D;  ///< k1 k2 p1 p2 [k3]; empty = none
};

/// Rectification of a stereo pair into one StereoCamera: per side, remap tables (absent when the
/// side needs no remap) and the rectifying rotation of the left camera (x_rect = R_left * x_raw).
/// Immutable after construction, so apply() may run on several threads at once (rectifier.cpp).
/// Remap tables need OpenCV: without it, the constructors that would need them throw DatasetError
/// saying so, and a pair that is rectified already passes through.
class Rectifier {
 public:
  /// Identity: images pass through unchanged.
  static Rectifier identity(const StereoCamera& camera);
  /// cv::stereoRectify of two raw cameras, x_cam1 = R * x_cam0 + t (T_cam1_cam0); alpha 0 (every
  /// rectified pixel sees the scene), CALIB_ZERO_DISPARITY, output size = cam0's. When the pair is
  /// already rectified (no distortion, same K, R = I, t along -x) nothing is remapped and the
  /// camera is cam0's K exactly.
  static Rectifier from_calibration(const RawCamera& cam0, const RawCamera& cam1, const Eigen::Matrix3d& R,
                                    const Eigen::Vector3d& t);
  /// ORB-SLAM2 LEFT.*/RIGHT.* (complete) with the rectified camera of the settings file.
  static Rectifier from_settings(const SettingsFile& settings, const StereoCamera& camera);
  /// Undistortion only (same K, R = I) of both sides, for a folder dataset whose settings file has
  /// nonzero Camera.k1.. but no LEFT/RIGHT block.
  static Rectifier undistort_only(const StereoCamera& camera, const std::vector<double>& D);

  const StereoCamera& camera() const { return camera_; }
  const Eigen::Matrix3d& left_rotation() const { return left_rotation_; }
  bool remaps() const { return tables_ != nullptr; }
  /// Expected raw image sizes (0 = any: checked against camera() then).
  int raw_width() const { return raw_width_; }
  int raw_height() const { return raw_height_; }
  /// "rectified (cv::stereoRectify, alpha 0)", "already rectified", ...
  const std::string& how() const { return how_; }

  /// Rectifies one raw 8-bit gray image of the left (side 0) or right (side 1) camera.
  Image apply(Image raw, int side) const;

 private:
  struct RemapTables;  // OpenCV maps (rectifier.cpp)
  StereoCamera camera_;
  Eigen::Matrix3d left_rotation_ = Eigen::Matrix3d::Identity();
  std::shared_ptr<const RemapTables> tables_;
  int raw_width_ = 0, raw_height_ = 0;
  std::string how_;
};

/// The readers (kitti_dataset.cpp, euroc_dataset.cpp, folder_dataset.cpp).
std::unique_ptr<StereoDataset> open_kitti(const fs::path& path, const DatasetOptions& options);
std::unique_ptr<StereoDataset> open_euroc(const fs::path& path, const DatasetOptions& options);
std::unique_ptr<StereoDataset> open_folder(const fs::path& path, const DatasetOptions& options);

/// DatasetOptions::settings_path read, or nullopt when empty; SettingsFileError becomes DatasetError.
std::optional<SettingsFile> read_settings_option(const DatasetOptions& options);

/// Formats a number with `digits` significant digits.
std::string format_number(double value, int digits = 6);

}  // namespace porta::slam::detail
