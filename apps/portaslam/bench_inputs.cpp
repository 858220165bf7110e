#include "bench_inputs.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#if PORTA_APPS_HAVE_OPENCV
#include <opencv2/imgproc.hpp>
#else
#include "plain_resize.hpp"
#endif

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
  std::vector<Image> left, right;
  std::string description;
  std::string pairing;  // what serves as the right image
};

Sequence load_kitti(const fs::path& data) {
  const fs::path folder = data / "kitti07-left-head" / "image_0";
  Sequence s;
  const auto names = png_names(folder);
  if (names.empty()) return s;
  for (const auto& name : names) s.left.push_back(load_gray_image((folder / name).string()).gray);
  for (std::size_t i = 0; i < s.left.size(); ++i) s.right.push_back(s.left[(i + 1) % s.left.size()]);
  s.description = "KITTI 07 left camera, frames " + fs::path(names.front()).stem().string() + ".." +
                  fs::path(names.back()).stem().string() + " (" + std::to_string(names.size()) + ", " +
                  std::to_string(s.left[0].width()) + "x" + std::to_string(s.left[0].height()) + ")";
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
    s.left.push_back(load_gray_image((cam0 / name).string()).gray);
    s.right.push_back(load_gray_image((cam1 / name).string()).gray);
  }
  s.description = "EuRoC V1_01 cam0, " + std::to_string(pairs.size()) + " frames (" +
                  std::to_string(s.left[0].width()) + "x" + std::to_string(s.left[0].height()) + ")";
  s.pairing = "stereo: cam1 of the same time (not rectified: timing only)";
  return s;
}

// Row y of the result is row (y + shift) mod height of the image.
Image roll_rows(const Image& image, int shift) {
  Image rolled(image.width(), image.height());
  for (int y = 0; y < image.height(); ++y)
    std::memcpy(rolled.row(y), image.row((y + shift) % image.height()), static_cast<std::size_t>(image.width()));
  return rolled;
}

// Rows rolled by k/8 of the height keep the pair's rows aligned while giving distinct bytes.
Sequence make_synthetic(const std::string& why) {
  const SyntheticStereoPair pair = make_synthetic_stereo_pair();
  const Image& left = pair.left;
  Sequence s;
  for (int k = 0; k < kSyntheticVariants; ++k) {
    const int shift = k * left.height() / kSyntheticVariants;
    s.left.push_back(roll_rows(left, shift));
    s.right.push_back(roll_rows(pair.right, shift));
  }
  s.description = "SYNTHETIC input (" + why + "): the built-in " + std::to_string(left.width()) + "x" +
                  std::to_string(left.height()) + " stereo pair in " + std::to_string(kSyntheticVariants) +
                  " variants with rows rolled by k/" + std::to_string(kSyntheticVariants) + " of the height";
  s.pairing = "stereo: its right image, rolled alike";
  return s;
}

// cv::resize with OpenCV, else its equivalent in plain_resize.cpp; area when shrinking, else bilinear.
Image resize(const ImageView& crop, Resolution size, bool shrink) {
#if PORTA_APPS_HAVE_OPENCV
  const cv::Mat in(crop.height, crop.width, CV_8U, const_cast<std::uint8_t*>(crop.data),
                   static_cast<std::size_t>(crop.pitch_bytes));
  cv::Mat out;
  cv::resize(in, out, cv::Size(size.width, size.height), 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
  return Image::copy_of({out.data, out.cols, out.rows, static_cast<int>(out.step)});
#else
  return shrink ? resize_area(crop, size.width, size.height) : resize_bilinear(crop, size.width, size.height);
#endif
}

// Centre crop to the target's aspect ratio, then resize (area when shrinking, bilinear otherwise).
Image fit(const Image& image, Resolution size, std::string& how) {
  if (image.width() == size.width && image.height() == size.height) {
    how = "used at their own size";
    return image;
  }
  int crop_width = image.width(), crop_height = image.height();
  const double target_aspect = static_cast<double>(size.width) / size.height;
  if (static_cast<double>(image.width()) / image.height() > target_aspect)
    crop_width = std::clamp(static_cast<int>(std::lround(image.height() * target_aspect)), 1, image.width());
  else
    crop_height = std::clamp(static_cast<int>(std::lround(image.width() / target_aspect)), 1, image.height());
  const int crop_x = (image.width() - crop_width) / 2, crop_y = (image.height() - crop_height) / 2;
  const ImageView crop{image.row(crop_y) + crop_x, crop_width, crop_height, image.pitch_bytes()};
  const bool shrink = crop_width >= size.width && crop_height >= size.height;
  Image out = resize(crop, size, shrink);
  how = "centre-cropped to " + std::to_string(crop_width) + "x" + std::to_string(crop_height) +
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
