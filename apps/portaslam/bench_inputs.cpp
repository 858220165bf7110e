#include "bench_inputs.hpp"

#include <algorithm>
#include <cstdlib>
#include <opencv2/imgproc.hpp>

#include "cli_args.hpp"
#include "image_files.hpp"
#include "synthetic_pair.hpp"

namespace porta::app {

namespace {

namespace fs = std::filesystem;

// Enough distinct frames to defeat cache warmth; more only costs loading time.
constexpr std::size_t kMaxSequenceFrames = 32;
constexpr int kSyntheticVariants = 8;
constexpr Resolution kEurocSize{752, 480};  // EuRoC's cameras: used as recorded at this size

cv::Mat to_mat(const Image& image) {
  return cv::Mat(image.height(), image.width(), CV_8U, const_cast<std::uint8_t*>(image.data()),
                 static_cast<std::size_t>(image.pitch_bytes()))
      .clone();
}

// The *.png files of a folder, sorted by name (KITTI and EuRoC name frames by index or time).
std::vector<std::string> png_names(const fs::path& folder) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder, ec))
    if (entry.is_regular_file(ec) && entry.path().extension() == ".png")
      names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  if (names.size() > kMaxSequenceFrames) names.resize(kMaxSequenceFrames);
  return names;
}

// A sequence as found on disk, before fitting to a resolution.
struct Sequence {
  std::vector<cv::Mat> left, right;
  std::string description;
  std::string pairing;  // what serves as the right image
};

Sequence load_kitti(const fs::path& data) {
  const fs::path folder = data / "kitti07-left-head" / "image_0";
  Sequence s;
  const auto names = png_names(folder);
  if (names.empty()) return s;
  for (const auto& name : names) s.left.push_back(to_mat(load_gray_image((folder / name).string()).gray));
  for (std::size_t i = 0; i < s.left.size(); ++i) s.right.push_back(s.left[(i + 1) % s.left.size()]);
  s.description = "KITTI 07 left camera, frames " + fs::path(names.front()).stem().string() + ".." +
                  fs::path(names.back()).stem().string() + " (" + std::to_string(names.size()) + ", " +
                  std::to_string(s.left[0].cols) + "x" + std::to_string(s.left[0].rows) + ")";
  s.pairing = "stereo: the next frame as the right image (timing only)";
  return s;
}

Sequence load_euroc(const fs::path& data) {
  const fs::path cam0 = data / "euroc-v101-head" / "mav0" / "cam0" / "data";
  const fs::path cam1 = data / "euroc-v101-head" / "mav0" / "cam1" / "data";
  Sequence s;
  std::vector<std::string> pairs;
  for (const auto& name : png_names(cam0))
    if (fs::exists(cam1 / name)) pairs.push_back(name);
  if (pairs.empty()) return s;
  for (const auto& name : pairs) {
    s.left.push_back(to_mat(load_gray_image((cam0 / name).string()).gray));
    s.right.push_back(to_mat(load_gray_image((cam1 / name).string()).gray));
  }
  s.description = "EuRoC V1_01 cam0, " + std::to_string(pairs.size()) + " frames (" +
                  std::to_string(s.left[0].cols) + "x" + std::to_string(s.left[0].rows) + ")";
  s.pairing = "stereo: cam1 of the same time (not rectified: timing only)";
  return s;
}

// Rows rolled by k/8 of the height keep the pair's rows aligned while giving distinct bytes.
Sequence make_synthetic(const std::string& why) {
  const SyntheticStereoPair pair = make_synthetic_stereo_pair();
  const cv::Mat left = to_mat(pair.left), right = to_mat(pair.right);
  Sequence s;
  for (int k = 0; k < kSyntheticVariants; ++k) {
    const int shift = k * left.rows / kSyntheticVariants;
    auto roll = [shift](const cv::Mat& m) {
      cv::Mat rolled;
      cv::vconcat(m.rowRange(shift, m.rows), m.rowRange(0, shift), rolled);
      return rolled;
    };
    s.left.push_back(shift ? roll(left) : left);
    s.right.push_back(shift ? roll(right) : right);
  }
  s.description = "SYNTHETIC input (" + why + "): the built-in " + std::to_string(left.cols) + "x" +
                  std::to_string(left.rows) + " stereo pair in " + std::to_string(kSyntheticVariants) +
                  " variants with rows rolled by k/" + std::to_string(kSyntheticVariants) + " of the height";
  s.pairing = "stereo: its right image, rolled alike";
  return s;
}

// Centre crop to the target's aspect ratio, then resize (area when shrinking, bilinear otherwise).
cv::Mat fit(const cv::Mat& image, Resolution size, std::string& how) {
  if (image.cols == size.width && image.rows == size.height) {
    how = "used at their own size";
    return image;
  }
  cv::Rect crop(0, 0, image.cols, image.rows);
  const double target_aspect = static_cast<double>(size.width) / size.height;
  if (static_cast<double>(image.cols) / image.rows > target_aspect)
    crop.width = std::clamp(static_cast<int>(std::lround(image.rows * target_aspect)), 1, image.cols);
  else
    crop.height = std::clamp(static_cast<int>(std::lround(image.cols / target_aspect)), 1, image.rows);
  crop.x = (image.cols - crop.width) / 2;
  crop.y = (image.rows - crop.height) / 2;
  const bool shrink = crop.width >= size.width && crop.height >= size.height;
  cv::Mat out;
  cv::resize(image(crop), out, cv::Size(size.width, size.height), 0, 0,
             shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
  how = "centre-cropped to " + std::to_string(crop.width) + "x" + std::to_string(crop.height) +
        " (the aspect of " + size.text() + ") and resized to it (" + (shrink ? "area" : "bilinear") + ")";
  return out;
}

bool is_folder(const fs::path& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

}  // namespace

DataFolder locate_data_folder(const std::string& cli_value) {
  auto given = [](const std::string& path, const std::string& origin) {
    if (!is_folder(path)) throw CliError("data folder '" + path + "' (from " + origin + ") is not a folder");
    return DataFolder{path, origin};
  };
  if (!cli_value.empty()) return given(cli_value, "--data");
  if (const char* env = std::getenv("PORTA_DATA_DIR"); env && *env) return given(env, "$PORTA_DATA_DIR");
  if (is_folder("../shared/data")) return {"../shared/data", "../shared/data from the current folder"};
  const fs::path beside_source = fs::path(PORTA_SOURCE_DIR) / ".." / "shared" / "data";
  if (is_folder(beside_source))
    return {beside_source.lexically_normal(), "../shared/data beside the source tree"};
  return {};
}

BenchFrames load_bench_frames(const DataFolder& data, Resolution size) {
  Sequence sequence;
  if (!data.path.empty()) {
    const bool euroc_size = size.width == kEurocSize.width && size.height == kEurocSize.height;
    if (euroc_size) sequence = load_euroc(data.path);
    if (sequence.left.empty()) sequence = load_kitti(data.path);
    if (sequence.left.empty() && !euroc_size) sequence = load_euroc(data.path);
  }
  BenchFrames frames;
  if (sequence.left.empty()) {
    sequence =
        make_synthetic(data.path.empty() ? "no data folder found; give --data DIR or set PORTA_DATA_DIR"
                                         : "no KITTI or EuRoC frames in " + data.path.string());
    frames.synthetic = true;
  }
  std::string how;
  for (std::size_t i = 0; i < sequence.left.size(); ++i) {
    frames.left.push_back(fit(sequence.left[i], size, how));
    frames.right.push_back(fit(sequence.right[i], size, how));
  }
  frames.source = sequence.description + ", " + how + "; " + sequence.pairing;
  return frames;
}

}  // namespace porta::app
