// EuRoC ASL: PATH/mav0 (or PATH = mav0) with cam0/ and cam1/ {data.csv, data/*.png, sensor.yaml};
// raw (distorted, unrectified) cameras, rectified here (dataset_common.cpp's Rectifier). Ground
// truth is of the body and is moved to the rectified left camera.
#include <cerrno>
#include <cmath>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>

#include "dataset_internal.hpp"
#include "yaml_reader.hpp"
#include "porta/settings.hpp"

namespace porta::slam::detail {

namespace {

struct CameraFrames {
  fs::path folder;                            ///< mav0/camN
  std::map<std::int64_t, std::string> files;  ///< timestamp (ns) -> file name in data/
};

std::string trimmed(const std::string& text) {
  const auto begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return {};
  return text.substr(begin, text.find_last_not_of(" \t\r\n") - begin + 1);
}

CameraFrames read_frames(const fs::path& folder) {
  CameraFrames frames;
  frames.folder = folder;
  const fs::path csv = folder / "data.csv";
  if (!is_file(csv)) fail("EuRoC camera folder " + in_quotes(folder) + " has no data.csv");
  if (!is_folder(folder / "data"))
    fail("EuRoC camera folder " + in_quotes(folder) + " has no data/ image folder");
  std::ifstream in(csv);
  if (!in) fail("cannot open " + in_quotes(csv) + ": " + std::strerror(errno));
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string text = trimmed(line);
    if (text.empty() || text[0] == '#') continue;
    const auto where = [&] {
      return "EuRoC image list " + in_quotes(csv) + " line " + std::to_string(number);
    };
    const auto comma = text.find(',');
    if (comma == std::string::npos) fail(where() + ": expected 'timestamp_ns,filename', got '" + text + "'");
    const std::string stamp = trimmed(text.substr(0, comma));
    const std::string name = trimmed(text.substr(comma + 1));
    std::int64_t ns = 0;
    const auto [end, error] = std::from_chars(stamp.data(), stamp.data() + stamp.size(), ns);
    if (error != std::errc() || end != stamp.data() + stamp.size() || ns < 0 || stamp.empty())
      fail(where() + ": '" + stamp + "' is not a timestamp in nanoseconds");
    if (name.empty() || name.find(',') != std::string::npos)
      fail(where() + ": expected one file name after the timestamp, got '" + text.substr(comma + 1) + "'");
    if (!frames.files.emplace(ns, name).second) fail(where() + ": timestamp " + stamp + " appears twice");
  }
  if (frames.files.empty()) fail("EuRoC image list " + in_quotes(csv) + " lists no images");
  return frames;
}

// ---- sensor.yaml ---------------------------------------------------------------------------------

class SensorReader {
 public:
  explicit SensorReader(const fs::path& path) : path_(path) {
    if (const auto error = read_yaml_file(path, root_))
      fail("EuRoC sensor file " + in_quotes(path) + ": " + *error);
  }

  [[noreturn]] void bad(const std::string& key, const std::string& problem) const {
    fail("EuRoC sensor file " + in_quotes(path_) + ": key '" + key + "' " + problem);
  }

  const YamlNode& required(const std::string& key) const {
    const YamlNode* node = root_.find(key);
    if (node == nullptr || node->is_null()) bad(key, "is missing");
    return *node;
  }

  std::vector<double> numbers(const YamlNode& node, const std::string& key, std::size_t min_count,
                              std::size_t max_count) const {
    if (node.kind != YamlNode::Kind::list) bad(key, "must be a list of numbers");
    std::vector<double> values;
    for (const auto& item : node.items) {
      if (!item.is_number()) bad(key, "must be a list of numbers");
      values.push_back(item.number);
      if (!std::isfinite(values.back())) bad(key, "has a value that is not finite");
    }
    if (values.size() < min_count || values.size() > max_count)
      bad(key, "has " + std::to_string(values.size()) + " numbers, expected " + std::to_string(min_count) +
                   (max_count != min_count ? " or " + std::to_string(max_count) : ""));
    return values;
  }

  std::optional<std::string> text(const std::string& key) const {
    const YamlNode* node = root_.find(key);
    if (node == nullptr || node->is_null()) return std::nullopt;
    if (node->kind != YamlNode::Kind::text) bad(key, "must be a text");
    return node->text;
  }

  RawCamera camera() const {
    if (const auto model = text("camera_model"); model && *model != "pinhole")
      bad("camera_model", "is '" + *model + "': only 'pinhole' is supported");
    RawCamera cam;
    const auto resolution = numbers(required("resolution"), "resolution", 2, 2);
    // Range first: casting a double beyond int's range is undefined behaviour.
    for (const double side : resolution) {
      if (!(side >= 1.0 && side <= kMaxImageSide) || side != std::floor(side))
        bad("resolution", "must be two integers [width, height] in [1, " + std::to_string(kMaxImageSide) + "], found " +
                              format_number(side));
    }
    cam.width = static_cast<int>(resolution[0]);
    cam.height = static_cast<int>(resolution[1]);
    const auto k = numbers(required("intrinsics"), "intrinsics", 4, 4);
    if (k[0] <= 0.0 || k[1] <= 0.0) bad("intrinsics", "must have focal lengths fu, fv > 0");
    cam.K(0, 0) = k[0];
    cam.K(1, 1) = k[1];
    cam.K(0, 2) = k[2];
    cam.K(1, 2) = k[3];
    const auto model = text("distortion_model").value_or("radial-tangential");
    if (model == "none") {
      cam.D.clear();
    } else if (model == "radial-tangential" || model == "radtan" || model == "plumb_bob") {
      cam.D = numbers(required("distortion_coefficients"), "distortion_coefficients", 4, 5);
      if (const auto problem = distortion_problem(cam.D)) bad("distortion_coefficients", "has a " + *problem);
    } else {
      bad("distortion_model", "is '" + model + "': only 'radial-tangential' (k1 k2 p1 p2 [k3]) is supported");
    }
    return cam;
  }

  SE3 body_to_sensor() const {
    const YamlNode& node = required("T_BS");
    const YamlNode* data = node.kind == YamlNode::Kind::map ? node.find("data") : &node;
    if (data == nullptr) bad("T_BS", "has no 'data' list");
    const auto values = numbers(*data, "T_BS", 16, 16);
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) m(r, c) = values[static_cast<std::size_t>(r * 4 + c)];
    if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9)
      bad("T_BS", "must be a rigid 4x4 transform (last row 0 0 0 1)");
    SE3 t = SE3::Identity();
    t.linear() = nearest_rotation(m.topLeftCorner<3, 3>(), "T_BS in EuRoC sensor file " + in_quotes(path_));
    t.translation() = m.topRightCorner<3, 1>();
    return t;
  }

 private:
  fs::path path_;
  YamlNode root_;
};

class EurocDataset final : public StereoDataset {
 public:
  EurocDataset(const fs::path& path, const DatasetOptions& options) : left_only_(options.left_only) {
    if (is_folder(path / "mav0")) {
      mav0_ = path / "mav0";
    } else if (is_folder(path / "cam0")) {
      mav0_ = path;
    } else {
      fail("EuRoC dataset " + in_quotes(path) + " has no mav0 folder (nor cam0/: not an EuRoC ASL sequence)");
    }
    for (const char* cam : {"cam0", "cam1"})
      if (!is_folder(mav0_ / cam))
        fail("EuRoC dataset " + in_quotes(mav0_) + " has no " + cam + " folder (" +
             (cam[3] == '0' ? "left" : "right") + " camera)");
    const SensorReader sensor0(mav0_ / "cam0" / "sensor.yaml");
    const SensorReader sensor1(mav0_ / "cam1" / "sensor.yaml");
    raw0_ = sensor0.camera();
    raw1_ = sensor1.camera();
    body_cam0_ = sensor0.body_to_sensor();
    const SE3 body_cam1 = sensor1.body_to_sensor();
    read_frames_and_pair();
    set_up_rectification(options, body_cam1);
    read_ground_truth_file(path, options);
  }

  std::string describe() const override {
    std::string text = "EuRoC " + mav0_.string() + ": " + std::to_string(size()) +
                       (left_only_ ? " frames (left camera only), " : " stereo frames, ") +
                       std::to_string(camera().width) + "x" + std::to_string(camera().height) + " " +
                       rectifier_.how() + ", baseline " + format_number(camera().baseline_m, 4) + " m";
    text += ground_truth_ ? ", ground truth " + std::to_string(ground_truth_->size()) + " poses from " +
                                ground_truth_source_.string()
                          : ", no ground truth";
    for (const auto& note : notes_) text += "; " + note;
    return text;
  }
  const StereoCamera& camera() const override { return rectifier_.camera(); }
  std::size_t size() const override { return frames_.size(); }
  double time_s(std::size_t index) const override { return seconds(frames_.at(check(index)).time_ns); }
  bool has_right() const override { return !left_only_; }
  const std::optional<Trajectory>& ground_truth() const override { return ground_truth_; }

  StereoPair load(std::size_t index) const override {
    const Frame& frame = frames_[check(index)];
    StereoPair pair;
    pair.index = index;
    pair.time_s = seconds(frame.time_ns);
    pair.left =
        rectifier_.apply(read_gray(mav0_ / "cam0" / "data" / frame.left, raw0_.width, raw0_.height), 0);
    if (!left_only_)
      pair.right =
          rectifier_.apply(read_gray(mav0_ / "cam1" / "data" / frame.right, raw1_.width, raw1_.height), 1);
    return pair;
  }

 private:
  struct Frame {
    std::int64_t time_ns = 0;
    std::string left, right;
  };

  // The raw nanoseconds / 1e9, nothing subtracted: the same base as the ground truth's time_s (a
  // double keeps ~240 ns at 1.4e9 s, far below the 50 ms frame interval).
  static double seconds(std::int64_t ns) { return static_cast<double>(ns) / 1e9; }

  std::size_t check(std::size_t index) const {
    if (index >= size())
      fail("frame index " + std::to_string(index) + " is out of range: EuRoC dataset " + in_quotes(mav0_) +
           " has " + std::to_string(size()) + " frames");
    return index;
  }

  void read_frames_and_pair() {
    const CameraFrames cam0 = read_frames(mav0_ / "cam0");
    if (left_only_) {
      for (const auto& [ns, name] : cam0.files) frames_.push_back({ns, name, {}});
    } else {
      const CameraFrames cam1 = read_frames(mav0_ / "cam1");
      std::size_t left_alone = 0;
      for (const auto& [ns, name] : cam0.files) {
        const auto right = cam1.files.find(ns);
        if (right == cam1.files.end()) {
          ++left_alone;
          continue;
        }
        frames_.push_back({ns, name, right->second});
      }
      const std::size_t right_alone = cam1.files.size() - frames_.size();
      if (frames_.empty())
        fail("EuRoC dataset " + in_quotes(mav0_) +
             ": no cam0 image has a cam1 image of the same timestamp (cam0 " +
             std::to_string(cam0.files.size()) + ", cam1 " + std::to_string(cam1.files.size()) + " images)");
      if (left_alone + right_alone > 0)
        notes_.push_back("dropped " + std::to_string(left_alone) + " cam0 and " +
                         std::to_string(right_alone) +
                         " cam1 images without a partner of the same timestamp");
    }
    for (const Frame& frame : frames_) {
      if (!is_file(mav0_ / "cam0" / "data" / frame.left))
        fail("EuRoC image " + in_quotes(mav0_ / "cam0" / "data" / frame.left) +
             " listed in cam0/data.csv is missing");
      if (!left_only_ && !is_file(mav0_ / "cam1" / "data" / frame.right))
        fail("EuRoC image " + in_quotes(mav0_ / "cam1" / "data" / frame.right) +
             " listed in cam1/data.csv is missing");
    }
  }

  void set_up_rectification(const DatasetOptions& options, const SE3& body_cam1) {
    if (const auto settings = read_settings_option(options)) {
      try {
        settings->check_rectification_complete();
        if (settings->has_rectification()) {
          const StereoCamera camera = settings->stereo_camera();
          if (*settings->left.width != raw0_.width || *settings->left.height != raw0_.height)
            fail("settings file " + in_quotes(settings->path) + ": LEFT is " +
                 std::to_string(*settings->left.width) + "x" + std::to_string(*settings->left.height) +
                 " but cam0/sensor.yaml says " + std::to_string(raw0_.width) + "x" +
                 std::to_string(raw0_.height));
          rectifier_ = Rectifier::from_settings(*settings, camera);
          return;
        }
      } catch (const SettingsFileError& e) {
        fail(e.what());
      }
      notes_.push_back("the settings file has no LEFT/RIGHT rectification: computed from sensor.yaml");
    }
    if (raw0_.width != raw1_.width || raw0_.height != raw1_.height)
      fail("EuRoC dataset " + in_quotes(mav0_) + ": cam0 is " + std::to_string(raw0_.width) + "x" +
           std::to_string(raw0_.height) + " but cam1 is " + std::to_string(raw1_.width) + "x" +
           std::to_string(raw1_.height) + "; rectification needs equal sizes");
    const SE3 cam1_cam0 = body_cam1.inverse() * body_cam0_;
    rectifier_ = Rectifier::from_calibration(raw0_, raw1_, cam1_cam0.linear(), cam1_cam0.translation());
  }

  void read_ground_truth_file(const fs::path& path, const DatasetOptions& options) {
    std::vector<fs::path> candidates;
    if (!options.ground_truth_path.empty()) {
      candidates.push_back(options.ground_truth_path);
    } else {
      candidates = {mav0_ / "state_groundtruth_estimate0" / "data.csv", path / "groundtruth_tum.txt",
                    mav0_.parent_path() / "groundtruth_tum.txt", mav0_ / "groundtruth_tum.txt"};
    }
    for (const fs::path& candidate : candidates) {
      if (options.ground_truth_path.empty() && !is_file(candidate)) continue;
      Trajectory trajectory = read_ground_truth(candidate);
      // T_world_camrect = T_world_body * T_body_cam0 * T_cam0_camrect, T_cam0_camrect = [R1^T | 0].
      SE3 cam0_rect = SE3::Identity();
      cam0_rect.linear() = rectifier_.left_rotation().transpose();
      const SE3 body_rect = body_cam0_ * cam0_rect;
      for (StampedPose& pose : trajectory.poses) pose.pose = pose.pose * body_rect;
      ground_truth_ = std::move(trajectory);
      ground_truth_source_ = candidate;
      return;
    }
  }

  fs::path mav0_;
  bool left_only_ = false;
  RawCamera raw0_, raw1_;
  SE3 body_cam0_ = SE3::Identity();
  std::vector<Frame> frames_;
  Rectifier rectifier_;
  std::optional<Trajectory> ground_truth_;
  fs::path ground_truth_source_;
  std::vector<std::string> notes_;
};

}  // namespace

std::unique_ptr<StereoDataset> open_euroc(const fs::path& path, const DatasetOptions& options) {
  return std::make_unique<EurocDataset>(path, options);
}

}  // namespace porta::slam::detail
