// KITTI odometry: PATH/image_0 (left), image_1 (right), calib.txt (P0..P3, rectified), times.txt,
// optional poses.txt (left camera poses; KITTI ships them elsewhere, hence ground_truth_path).
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "dataset_internal.hpp"

namespace porta::slam::detail {

namespace {

using Projection = std::array<double, 12>;  // 3x4, row by row

struct KittiCalibration {
  std::optional<Projection> P[4];
};

KittiCalibration read_calibration(const fs::path& path) {
  std::ifstream in(path);
  if (!in) fail("cannot open KITTI calibration " + in_quotes(path) + ": " + std::strerror(errno));
  KittiCalibration calib;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.find_first_not_of(" \t\r\n") == std::string::npos) continue;
    const auto where = [&] {
      return "KITTI calibration " + in_quotes(path) + " line " + std::to_string(number);
    };
    const auto colon = line.find(':');
    if (colon == std::string::npos) fail(where() + ": expected 'NAME: numbers' (e.g. 'P0: 12 numbers')");
    std::string key = line.substr(0, colon);
    key.erase(0, key.find_first_not_of(" \t"));
    key.erase(key.find_last_not_of(" \t") + 1);
    if (key.size() != 2 || key[0] != 'P' || key[1] < '0' || key[1] > '3') continue;  // Tr, ... unused
    std::istringstream fields(line.substr(colon + 1));
    Projection p{};
    std::size_t count = 0;
    std::string token;
    while (fields >> token) {
      std::size_t used = 0;
      double value = 0.0;
      try {
        value = std::stod(token, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != token.size() || !std::isfinite(value))
        fail(where() + ": '" + token + "' in " + key + " is not a number");
      if (count < p.size()) p[count] = value;
      ++count;
    }
    if (count != 12)
      fail(where() + ": " + key + " has " + std::to_string(count) +
           " numbers, expected 12 (a 3x4 matrix row by row)");
    calib.P[key[1] - '0'] = p;
  }
  return calib;
}

class KittiDataset final : public StereoDataset {
 public:
  KittiDataset(const fs::path& root, const DatasetOptions& options)
      : root_(root), left_only_(options.left_only) {
    left_dir_ = root_ / "image_0";
    right_dir_ = root_ / "image_1";
    if (!is_folder(left_dir_))
      fail("KITTI dataset " + in_quotes(root_) + " has no image_0 folder (left camera)");
    if (!left_only_ && !is_folder(right_dir_))
      fail("KITTI dataset " + in_quotes(root_) +
           " has no image_1 folder (right camera); open it left-only (DatasetOptions::left_only, "
           "--left-only) to read the left images alone");
    names_ = list_image_names(left_dir_, "KITTI left image folder");
    if (!left_only_)
      require_same_names(names_, left_dir_, list_image_names(right_dir_, "KITTI right image folder"),
                         right_dir_);
    read_camera(options);
    read_times();
    read_poses(options);
  }

  std::string describe() const override {
    std::string text = "KITTI " + root_.string() + ": " + std::to_string(size()) +
                       (left_only_ ? " frames (left camera only), " : " stereo frames, ") +
                       std::to_string(camera_.width) + "x" + std::to_string(camera_.height) + ", baseline " +
                       format_number(camera_.baseline_m, 4) + " m";
    text += ground_truth_ ? ", ground truth " + std::to_string(ground_truth_->size()) + " poses"
                          : ", no ground truth";
    for (const auto& note : notes_) text += "; " + note;
    return text;
  }
  const StereoCamera& camera() const override { return camera_; }
  std::size_t size() const override { return names_.size(); }
  double time_s(std::size_t index) const override { return times_.at(check(index)); }
  bool has_right() const override { return !left_only_; }
  const std::optional<Trajectory>& ground_truth() const override { return ground_truth_; }

  StereoPair load(std::size_t index) const override {
    StereoPair pair;
    pair.index = check(index);
    pair.time_s = times_[index];
    pair.left = read_gray(left_dir_ / names_[index], camera_.width, camera_.height);
    if (!left_only_)
      pair.right = read_gray(right_dir_ / names_[index], camera_.width, camera_.height);
    return pair;
  }

 private:
  std::size_t check(std::size_t index) const {
    if (index >= size())
      fail("frame index " + std::to_string(index) + " is out of range: KITTI dataset " + in_quotes(root_) +
           " has " + std::to_string(size()) + " frames");
    return index;
  }

  void read_camera(const DatasetOptions& options) {
    const auto settings = read_settings_option(options);
    const fs::path calib_path = root_ / "calib.txt";
    // The image size is not in calib.txt: the first left image gives it.
    const Image first = read_gray(left_dir_ / names_.front());
    if (is_file(calib_path)) {
      const KittiCalibration calib = read_calibration(calib_path);
      for (int i = 0; i < 2; ++i)
        if (!calib.P[i])
          fail("KITTI calibration " + in_quotes(calib_path) + " has no P" + std::to_string(i) + " line");
      const Projection& p0 = *calib.P[0];
      const Projection& p1 = *calib.P[1];
      camera_.width = first.width();
      camera_.height = first.height();
      camera_.fx = p0[0];
      camera_.fy = p0[5];
      camera_.cx = p0[2];
      camera_.cy = p0[6];
      camera_.baseline_m = p1[0] != 0.0 ? -p1[3] / p1[0] : 0.0;
      try {
        camera_.validate();
      } catch (const std::invalid_argument& e) {
        fail("KITTI calibration " + in_quotes(calib_path) +
             " (camera from P0, baseline -P1[0][3]/P1[0][0]): " + e.what());
      }
      if (settings && settings->fx && std::abs(*settings->fx - camera_.fx) > 1e-3)
        notes_.push_back("camera from calib.txt (the settings file's Camera.fx " +
                         format_number(*settings->fx) + " differs and is not used)");
      return;
    }
    if (!settings)
      fail("KITTI dataset " + in_quotes(root_) +
           " has no calib.txt, and no settings file was given for the camera");
    try {
      camera_ = settings->stereo_camera();
    } catch (const SettingsFileError& e) {
      fail(e.what());
    }
    if (camera_.width != first.width() || camera_.height != first.height())
      fail("settings file " + in_quotes(settings->path) + " says the images are " +
           std::to_string(camera_.width) + "x" + std::to_string(camera_.height) + " but " +
           in_quotes(left_dir_ / names_.front()) + " is " + std::to_string(first.width()) + "x" +
           std::to_string(first.height()));
    notes_.push_back("camera from the settings file (no calib.txt)");
  }

  void read_times() {
    times_path_ = root_ / "times.txt";
    if (!is_file(times_path_)) {
      times_path_.clear();
      for (std::size_t i = 0; i < size(); ++i) times_.push_back(0.1 * static_cast<double>(i));
      notes_.push_back("no times.txt: 10 Hz assumed");
      return;
    }
    times_ = read_times_file(times_path_);
    if (times_.size() != size())
      fail("times file " + in_quotes(times_path_) + " has " + std::to_string(times_.size()) + " times but " +
           in_quotes(left_dir_) + " has " + std::to_string(size()) + " images");
  }

  void read_poses(const DatasetOptions& options) {
    fs::path path = options.ground_truth_path;
    if (path.empty()) {
      path = root_ / "poses.txt";
      if (!is_file(path)) return;
    }
    Trajectory trajectory = read_ground_truth(path);
    if (!trajectory.has_times) {
      // A KITTI pose file: pose i is frame i.
      if (trajectory.size() > size()) {
        notes_.push_back("ground truth has " + std::to_string(trajectory.size()) + " poses: the first " +
                         std::to_string(size()) + " are used");
        trajectory.poses.resize(size());
      } else if (trajectory.size() < size()) {
        notes_.push_back("ground truth covers the first " + std::to_string(trajectory.size()) +
                         " frames only");
      }
      for (std::size_t i = 0; i < trajectory.size(); ++i) trajectory.poses[i].time_s = times_[i];
      trajectory.has_times = true;
    }
    ground_truth_ = std::move(trajectory);
  }

  fs::path root_, left_dir_, right_dir_, times_path_;
  bool left_only_ = false;
  std::vector<std::string> names_;
  std::vector<double> times_;
  StereoCamera camera_;
  std::optional<Trajectory> ground_truth_;
  std::vector<std::string> notes_;
};

}  // namespace

std::unique_ptr<StereoDataset> open_kitti(const fs::path& path, const DatasetOptions& options) {
  return std::make_unique<KittiDataset>(path, options);
}

}  // namespace porta::slam::detail
