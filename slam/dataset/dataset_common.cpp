#include <Eigen/SVD>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#if PORTA_DATASET_HAVE_OPENCV
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#endif
#include <sstream>

#include "dataset_internal.hpp"
#include "imageio/png_file.hpp"
#include "porta/settings.hpp"
#include "porta/slam/trajectory_io.hpp"

namespace porta::slam::detail {

std::string in_quotes(const fs::path& path) {
  // Appended piecewise: GCC 12 reports a false -Wrestrict on "'" + text + "'" here.
  std::string quoted(1, '\'');
  quoted += path.string();
  quoted += '\'';
  return quoted;
}

void fail(const std::string& message) { throw DatasetError(message); }

bool is_folder(const fs::path& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

bool is_file(const fs::path& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

void require_folder(const fs::path& path, const std::string& what) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) fail(what + " " + in_quotes(path) + " does not exist");
  if (!fs::is_directory(status)) fail(what + " " + in_quotes(path) + " is not a folder");
}

namespace {

bool has_image_extension(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  static const char* const kExtensions[] = {".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".bmp", ".tif", ".tiff"};
  return std::any_of(std::begin(kExtensions), std::end(kExtensions), [&](const char* e) { return ext == e; });
}

std::string trim(const std::string& text) {
  const auto begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return {};
  const auto end = text.find_last_not_of(" \t\r\n");
  return text.substr(begin, end - begin + 1);
}

}  // namespace

std::vector<std::string> list_image_names(const fs::path& folder, const std::string& what) {
  require_folder(folder, what);
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec) && !it->is_symlink(ec)) continue;
    if (has_image_extension(it->path())) names.push_back(it->path().filename().string());
  }
  if (ec) fail("cannot list " + what + " " + in_quotes(folder) + ": " + ec.message());
  if (names.empty())
    fail(what + " " + in_quotes(folder) + " has no image files (.png, .jpg, .pgm, .ppm, .bmp, .tif)");
  std::sort(names.begin(), names.end());
  return names;
}

void require_same_names(const std::vector<std::string>& left, const fs::path& left_folder,
                        const std::vector<std::string>& right, const fs::path& right_folder) {
  if (left.size() != right.size())
    fail("left and right image folders differ in size: " + in_quotes(left_folder) + " has " +
         std::to_string(left.size()) + " images, " + in_quotes(right_folder) + " has " +
         std::to_string(right.size()));
  for (std::size_t i = 0; i < left.size(); ++i) {
    if (left[i] != right[i])
      fail("left and right image names differ at position " + std::to_string(i) + ": " +
           in_quotes(left_folder / left[i]) + " against " + in_quotes(right_folder / right[i]) +
           " (pairs are matched by name)");
  }
}

std::vector<double> read_times_file(const fs::path& path) {
  std::ifstream in(path);
  if (!in) fail("cannot open times file " + in_quotes(path) + ": " + std::strerror(errno));
  std::vector<double> times;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string text = trim(line);
    if (text.empty() || text[0] == '#') continue;
    double t = 0.0;
    std::istringstream fields(text);
    std::string rest;
    if (!(fields >> t) || (fields >> rest) || !std::isfinite(t))
      fail("times file " + in_quotes(path) + " line " + std::to_string(number) +
           ": expected one time in seconds, got '" + text + "'");
    if (std::abs(t) > kMaxTimeS)
      fail("times file " + in_quotes(path) + " line " + std::to_string(number) + ": the time " + format_number(t) +
           " s is outside [-" + format_number(kMaxTimeS) + ", " + format_number(kMaxTimeS) + "] s");
    if (!times.empty() && !(t > times.back()))
      fail("times file " + in_quotes(path) + " line " + std::to_string(number) + ": the time " + format_number(t, 12) +
           " s does not come after the one before (" + format_number(times.back(), 12) +
           " s); times must increase, one per frame");
    times.push_back(t);
  }
  if (times.empty()) fail("times file " + in_quotes(path) + " has no times");
  return times;
}

#if PORTA_DATASET_HAVE_OPENCV
namespace {

// 16-bit and float images keep their full range through a linear map to [0, 255] (as portaslam's
// apps/portaslam/image_files.cpp does, so both read a file to the same bytes).
cv::Mat to_8bit(const cv::Mat& m) {
  if (m.depth() == CV_8U) return m;
  cv::Mat out;
  if (m.depth() == CV_16U) {
    m.convertTo(out, CV_8U, 1.0 / 257.0);
    return out;
  }
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(m.reshape(1), &lo, &hi);
  m.convertTo(out, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0, hi > lo ? -lo * 255.0 / (hi - lo) : 0.0);
  return out;
}

/// A non-PNG image file through OpenCV's decoders, to 8-bit gray.
Image read_gray_with_opencv(const fs::path& path) {
  cv::Mat decoded;
  try {
    decoded = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    fail("cannot decode image " + in_quotes(path) + ": " +
         (e.code == cv::Error::StsNoMem ? std::string("too large to decode (out of memory)")
                                        : "corrupt or unsupported (" + e.err + ")"));
  }
  if (decoded.empty())
    fail("cannot decode image " + in_quotes(path) +
         ": not an image file OpenCV can read (corrupt, truncated, or not an image)");
  cv::Mat gray = to_8bit(decoded);
  if (gray.channels() != 1) {
    cv::Mat single;
    if (gray.channels() == 3 || gray.channels() == 4)
      cv::cvtColor(gray, single, gray.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    else
      cv::extractChannel(gray, single, 0);  // gray + alpha: keep the gray
    gray = single;
  }
  Image image(gray.cols, gray.rows);
  for (int y = 0; y < gray.rows; ++y)
    std::memcpy(image.row(y), gray.ptr<std::uint8_t>(y), static_cast<std::size_t>(gray.cols));
  return image;
}

}  // namespace
#endif

Image read_gray(const fs::path& path, int width, int height) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) fail("image " + in_quotes(path) + " is missing");
  if (fs::is_directory(status)) fail("image " + in_quotes(path) + " is a folder, not an image file");
  Image gray;
  if (io::has_png_signature(path.string())) {
    // PNG through libpng (the bytes OpenCV would give, png_file.hpp) with the size checked before
    // any pixel is allocated, and our messages instead of a library's.
    try {
      gray = std::move(io::read_png_gray(path.string(), kMaxImageSide).gray);
    } catch (const io::PngError& e) {
      if (e.kind() == io::PngError::Kind::too_large)
        fail("image " + in_quotes(path) + " is " + std::to_string(e.width()) + "x" + std::to_string(e.height()) +
             ": larger than the limit of " + std::to_string(kMaxImageSide) + " px per side");
      fail("cannot decode image " + in_quotes(path) + ": " + e.what());
    }
  } else {
#if PORTA_DATASET_HAVE_OPENCV
    gray = read_gray_with_opencv(path);
#else
    fail("cannot read image " + in_quotes(path) + ": not a PNG file, and this build of PortaSLAM reads other "
         "formats only with OpenCV, which it was built without");
#endif
  }
  if (width > 0 && height > 0 && (gray.width() != width || gray.height() != height))
    fail("image " + in_quotes(path) + " is " + std::to_string(gray.width()) + "x" + std::to_string(gray.height()) +
         ", expected " + std::to_string(width) + "x" + std::to_string(height) + " like the rest of the dataset");
  return gray;
}

std::optional<std::string> distortion_problem(const std::vector<double>& coefficients) {
  static const char* const kNames[] = {"k1", "k2", "p1", "p2", "k3"};
  for (std::size_t i = 0; i < coefficients.size(); ++i) {
    const double v = coefficients[i];
    if (std::isfinite(v) && std::abs(v) <= kMaxDistortionCoefficient) continue;
    return "distortion coefficient " + std::to_string(i + 1) + (i < 5 ? std::string(" (") + kNames[i] + ")" : "") +
           " is " + format_number(v) + ", outside [-" + format_number(kMaxDistortionCoefficient) + ", " +
           format_number(kMaxDistortionCoefficient) + "]";
  }
  return std::nullopt;
}

Trajectory read_ground_truth(const fs::path& path, const std::string& kitti_times_path) {
  try {
    const TrajectoryFormat format = detect_trajectory_format(path.string());
    return read_trajectory(path.string(), format, format == TrajectoryFormat::kitti ? kitti_times_path : "");
  } catch (const TrajectoryError& e) {
    fail(std::string("ground truth: ") + e.what());
  }
}

Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& m, const std::string& what) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0.0 || (r - m).cwiseAbs().maxCoeff() > 1e-3 || !m.allFinite())
    fail(what + " is not a rotation (its 3x3 block must be orthonormal with determinant +1)");
  return r;
}

std::string format_number(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

}  // namespace porta::slam::detail
