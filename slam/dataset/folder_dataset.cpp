// Generic stereo folder: PATH/left + PATH/right (or image_0 + image_1, or cam0 + cam1) of images with
// the same sorted names, the camera from an ORB-SLAM2 settings file, optional PATH/times.txt.
#include <utility>

#include "dataset_internal.hpp"

namespace porta::slam::detail {

namespace {

class FolderDataset final : public StereoDataset {
 public:
  FolderDataset(const fs::path& root, const DatasetOptions& options)
      : root_(root), left_only_(options.left_only) {
    find_folders();
    names_ = list_image_names(left_dir_, "left image folder");
    if (!left_only_)
      require_same_names(names_, left_dir_, list_image_names(right_dir_, "right image folder"), right_dir_);

    const auto settings = read_settings_option(options);
    if (!settings)
      fail("stereo folder " + in_quotes(root_) +
           " needs a settings file for its camera (DatasetOptions::settings_path, --settings FILE; ORB-SLAM2 "
           "YAML "
           "with Camera.fx, fy, cx, cy, bf, width, height)");
    try {
      const StereoCamera camera = settings->stereo_camera();
      settings->check_rectification_complete();
      if (settings->has_rectification()) {
        rectifier_ = Rectifier::from_settings(*settings, camera);
      } else if (settings->has_distortion()) {
        rectifier_ = Rectifier::undistort_only(
            camera, {settings->k1.value_or(0.0), settings->k2.value_or(0.0), settings->p1.value_or(0.0),
                     settings->p2.value_or(0.0), settings->k3.value_or(0.0)});
      } else {
        rectifier_ = Rectifier::identity(camera);
      }
    } catch (const SettingsFileError& e) {
      fail(e.what());
    }
    read_times(settings->fps);
    if (!options.ground_truth_path.empty()) {
      Trajectory trajectory = read_ground_truth(options.ground_truth_path);
      if (!trajectory.has_times) {
        if (trajectory.size() > size()) trajectory.poses.resize(size());
        for (std::size_t i = 0; i < trajectory.size(); ++i) trajectory.poses[i].time_s = times_[i];
        trajectory.has_times = true;
      }
      ground_truth_ = std::move(trajectory);
    }
  }

  std::string describe() const override {
    std::string text = "stereo folder " + root_.string() + ": " + std::to_string(size()) +
                       (left_only_ ? " frames (left camera only) in " : " stereo frames in ");
    text += left_dir_.filename().string();
    if (!left_only_) text.append(1, '/').append(right_dir_.filename().string());
    text += ", " + std::to_string(camera().width) + "x" + std::to_string(camera().height) + " " +
            rectifier_.how() + ", baseline " + format_number(camera().baseline_m, 4) + " m";
    text += ground_truth_ ? ", ground truth " + std::to_string(ground_truth_->size()) + " poses"
                          : ", no ground truth";
    for (const auto& note : notes_) text += "; " + note;
    return text;
  }
  const StereoCamera& camera() const override { return rectifier_.camera(); }
  std::size_t size() const override { return names_.size(); }
  double time_s(std::size_t index) const override { return times_.at(check(index)); }
  bool has_right() const override { return !left_only_; }
  const std::optional<Trajectory>& ground_truth() const override { return ground_truth_; }

  StereoPair load(std::size_t index) const override {
    StereoPair pair;
    pair.index = check(index);
    pair.time_s = times_[index];
    const int w = rectifier_.raw_width(), h = rectifier_.raw_height();
    pair.left = rectifier_.apply(read_gray(left_dir_ / names_[index], w, h), 0);
    if (!left_only_) pair.right = rectifier_.apply(read_gray(right_dir_ / names_[index], w, h), 1);
    return pair;
  }

 private:
  std::size_t check(std::size_t index) const {
    if (index >= size())
      fail("frame index " + std::to_string(index) + " is out of range: stereo folder " + in_quotes(root_) +
           " has " + std::to_string(size()) + " frames");
    return index;
  }

  void find_folders() {
    static const std::pair<const char*, const char*> kNames[] = {
        {"left", "right"}, {"image_0", "image_1"}, {"cam0", "cam1"}};
    for (const auto& [left, right] : kNames) {
      if (!is_folder(root_ / left)) continue;
      left_dir_ = root_ / left;
      right_dir_ = root_ / right;
      if (!left_only_ && !is_folder(right_dir_))
        fail("stereo folder " + in_quotes(root_) + " has a " + left + " folder but no " + right +
             " folder (right camera); open it left-only to read the left images alone");
      return;
    }
    fail("stereo folder " + in_quotes(root_) +
         " has no left/ and right/ image folders (image_0/image_1 and " + "cam0/cam1 are accepted too)");
  }

  void read_times(const std::optional<double>& fps) {
    const fs::path path = root_ / "times.txt";
    if (is_file(path)) {
      times_ = read_times_file(path);
      if (times_.size() != size())
        fail("times file " + in_quotes(path) + " has " + std::to_string(times_.size()) + " times but " +
             in_quotes(left_dir_) + " has " + std::to_string(size()) + " images");
      return;
    }
    const double interval = fps ? 1.0 / *fps : 0.1;
    for (std::size_t i = 0; i < size(); ++i) times_.push_back(static_cast<double>(i) * interval);
    notes_.push_back(fps ? "no times.txt: times from Camera.fps"
                         : "no times.txt and no Camera.fps: 10 Hz assumed");
  }

  fs::path root_, left_dir_, right_dir_;
  bool left_only_ = false;
  std::vector<std::string> names_;
  std::vector<double> times_;
  Rectifier rectifier_;
  std::optional<Trajectory> ground_truth_;
  std::vector<std::string> notes_;
};

}  // namespace

std::unique_ptr<StereoDataset> open_folder(const fs::path& path, const DatasetOptions& options) {
  return std::make_unique<FolderDataset>(path, options);
}

}  // namespace porta::slam::detail
