// Stereo datasets on disk: KITTI odometry, EuRoC ASL and a generic stereo folder, all presented as a
// sequence of *rectified* 8-bit gray stereo pairs with one StereoCamera (DESIGN.md §6, §7).
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "porta/image.hpp"
#include "porta/slam/pose.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam {

enum class DatasetKind { kitti, euroc, folder };
/// "kitti", "euroc", "folder"; nullopt otherwise.
std::optional<DatasetKind> parse_dataset_kind(std::string_view name);
const char* to_string(DatasetKind kind);

/// A dataset that is missing, empty, inconsistent or corrupt. what() names the path and the problem.
class DatasetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One rectified stereo pair.
struct StereoPair {
  std::size_t index = 0;
  double time_s = 0.0;
  Image left, right;  ///< packed 8-bit gray, camera().width x camera().height
};

class StereoDataset {
 public:
  virtual ~StereoDataset() = default;
  /// e.g. "EuRoC /data/V101/mav0: 24 stereo frames, 752x480 rectified, baseline 0.1101 m"
  virtual std::string describe() const = 0;
  /// The rectified camera every pair is delivered in.
  virtual const StereoCamera& camera() const = 0;
  virtual std::size_t size() const = 0;
  virtual double time_s(std::size_t index) const = 0;
  /// Loads (and for EuRoC rectifies) pair `index` < size(). Safe to call from several threads.
  /// Throws DatasetError naming the file when an image is missing, corrupt or of the wrong size.
  virtual StereoPair load(std::size_t index) const = 0;
  /// Ground truth of the *rectified left camera* (T_world_cam), when the dataset has it: KITTI
  /// poses.txt, EuRoC's ground-truth CSV (body poses moved to the camera with T_BS and the
  /// rectification rotation). Times are in the same base as time_s().
  virtual const std::optional<Trajectory>& ground_truth() const = 0;
  /// False when the dataset was opened left-only (DatasetOptions::left_only): StereoPair::right is
  /// then empty. camera() still carries the baseline from the calibration.
  virtual bool has_right() const { return true; }
};

/// Options that override what the dataset's own files say.
struct DatasetOptions {
  /// ORB-SLAM2-style YAML settings file (camera intrinsics/baseline; for EuRoC, optionally the
  /// LEFT/RIGHT.K,D,R,P rectification). Required for `folder` datasets without a calib file.
  std::string settings_path;
  /// Ground-truth file to use instead of the one found in the dataset (any trajectory format).
  /// KITTI: poses of the left camera (a KITTI file without times takes times.txt's times, pose i
  /// being frame i). EuRoC: body poses, moved to the rectified left camera like the dataset's own.
  /// Folder: poses of the (rectified) left camera.
  std::string ground_truth_path;
  /// Read the left images only (KITTI and folder datasets may then lack the right image folder;
  /// EuRoC still needs cam1's calibration to rectify). StereoPair::right stays empty.
  bool left_only = false;
};

/// Opens a dataset, reading its index files and calibration (not the images). Throws DatasetError.
std::unique_ptr<StereoDataset> open_dataset(DatasetKind kind, const std::string& path,
                                            const DatasetOptions& options = {});

}  // namespace porta::slam
