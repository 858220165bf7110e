#include <Eigen/SVD>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
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

}  // namespace

cv::Mat read_gray(const fs::path& path, int width, int height) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status)) fail("image " + in_quotes(path) + " is missing");
  if (fs::is_directory(status)) fail("image " + in_quotes(path) + " is a folder, not an image file");
  if (io::has_png_signature(path.string())) {
    // PNG through libpng (the bytes OpenCV would give, png_file.hpp) with the size checked before
    // any pixel is allocated, and our messages instead of a library's.
    try {
      io::GrayPng png = io::read_png_gray(path.string(), kMaxImageSide);
      cv::Mat gray(png.gray.height(), png.gray.width(), CV_8UC1);
      for (int y = 0; y < gray.rows; ++y)
        std::memcpy(gray.ptr<std::uint8_t>(y), png.gray.row(y), static_cast<std::size_t>(gray.cols));
      if (width > 0 && height > 0 && (gray.cols != width || gray.rows != height))
        fail("image " + in_quotes(path) + " is " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
             ", expected " + std::to_string(width) + "x" + std::to_string(height) + " like the rest of the dataset");
      return gray;
    } catch (const io::PngError& e) {
      if (e.kind() == io::PngError::Kind::too_large)
        fail("image " + in_quotes(path) + " is " + std::to_string(e.width()) + "x" + std::to_string(e.height()) +
             ": larger than the limit of " + std::to_string(kMaxImageSide) + " px per side");
      fail("cannot decode image " + in_quotes(path) + ": " + e.what());
    }
  }
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
  if (width > 0 && height > 0 && (gray.cols != width || gray.rows != height))
    fail("image " + in_quotes(path) + " is " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
         ", expected " + std::to_string(width) + "x" + std::to_string(height) +
         " like the rest of the dataset");
  return gray;
}

Image to_image(const cv::Mat& gray) {
  Image image(gray.cols, gray.rows);
  for (int y = 0; y < gray.rows; ++y)
    std::memcpy(image.row(y), gray.ptr<std::uint8_t>(y), static_cast<std::size_t>(gray.cols));
  return image;
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

// ---- Rectifier -----------------------------------------------------------------------------------

namespace {

cv::Mat to_cv(const Eigen::MatrixXd& m) {
  cv::Mat out(static_cast<int>(m.rows()), static_cast<int>(m.cols()), CV_64F);
  for (int r = 0; r < out.rows; ++r)
    for (int c = 0; c < out.cols; ++c) out.at<double>(r, c) = m(r, c);
  return out;
}

cv::Mat distortion_to_cv(const std::vector<double>& D) {
  cv::Mat out(1, std::max<int>(4, static_cast<int>(D.size())), CV_64F, cv::Scalar(0.0));
  for (std::size_t i = 0; i < D.size(); ++i) out.at<double>(0, static_cast<int>(i)) = D[i];
  return out;
}

bool all_zero(const std::vector<double>& values) {
  return std::all_of(values.begin(), values.end(), [](double v) { return v == 0.0; });
}

StereoCamera validated(StereoCamera camera, const std::string& source) {
  try {
    camera.validate();
  } catch (const std::invalid_argument& e) {
    fail(source + ": " + e.what());
  }
  return camera;
}

/// Runs an OpenCV step of building or applying a rectification; an OpenCV assertion (a degenerate
/// calibration: zero baseline, a singular K, ...) becomes a DatasetError in our words, so that no
/// library text is all the user sees.
template <typename Step>
void opencv_step(const std::string& what, Step&& step) {
  try {
    step();
  } catch (const cv::Exception& e) {
    fail(what + " failed: the calibration is degenerate or inconsistent (OpenCV: " + e.err + ")");
  }
}

}  // namespace

Rectifier Rectifier::identity(const StereoCamera& camera) {
  Rectifier r;
  r.camera_ = camera;
  r.raw_width_ = camera.width;
  r.raw_height_ = camera.height;
  r.how_ = "rectified images (no remap)";
  return r;
}

Rectifier Rectifier::from_calibration(const RawCamera& cam0, const RawCamera& cam1, const Eigen::Matrix3d& R,
                                      const Eigen::Vector3d& t) {
  Rectifier r;
  r.raw_width_ = cam0.width;
  r.raw_height_ = cam0.height;

  // A pair that is rectified already (a rendered sequence): keep its camera bit for bit.
  const double rotation_error = rotation_angle_rad(R);
  const bool same_k =
      (cam0.K - cam1.K).cwiseAbs().maxCoeff() <= 1e-9 * std::max(1.0, cam0.K.cwiseAbs().maxCoeff());
  const bool pinhole =
      cam0.K(0, 1) == 0.0 && cam0.K(1, 0) == 0.0 && cam0.K(2, 0) == 0.0 && cam0.K(2, 1) == 0.0;
  if (all_zero(cam0.D) && all_zero(cam1.D) && same_k && pinhole && cam0.width == cam1.width &&
      cam0.height == cam1.height && rotation_error < 1e-6 && t.x() < 0.0 &&
      std::abs(t.y()) <= 1e-6 * std::abs(t.x()) && std::abs(t.z()) <= 1e-6 * std::abs(t.x())) {
    r.camera_.width = cam0.width;
    r.camera_.height = cam0.height;
    r.camera_.fx = cam0.K(0, 0);
    r.camera_.fy = cam0.K(1, 1);
    r.camera_.cx = cam0.K(0, 2);
    r.camera_.cy = cam0.K(1, 2);
    r.camera_.baseline_m = -t.x();
    r.camera_ = validated(r.camera_, "stereo calibration");
    r.how_ = "already rectified (no distortion, parallel cameras): no remap";
    return r;
  }

  const cv::Size size(cam0.width, cam0.height);
  cv::Mat R1, R2, P1, P2, Q;
  opencv_step("stereo rectification from the two cameras' calibration", [&] {
    cv::stereoRectify(to_cv(cam0.K), distortion_to_cv(cam0.D), to_cv(cam1.K), distortion_to_cv(cam1.D), size,
                      to_cv(R), to_cv(t), R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0, size);
    cv::initUndistortRectifyMap(to_cv(cam0.K), distortion_to_cv(cam0.D), R1, P1, size, CV_32FC1, r.left_map_x_,
                                r.left_map_y_);
    cv::initUndistortRectifyMap(to_cv(cam1.K), distortion_to_cv(cam1.D), R2, P2, size, CV_32FC1, r.right_map_x_,
                                r.right_map_y_);
  });
  r.camera_.width = cam0.width;
  r.camera_.height = cam0.height;
  r.camera_.fx = P1.at<double>(0, 0);
  r.camera_.fy = P1.at<double>(1, 1);
  r.camera_.cx = P1.at<double>(0, 2);
  r.camera_.cy = P1.at<double>(1, 2);
  r.camera_.baseline_m = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
  r.camera_ = validated(r.camera_, "stereo rectification (cv::stereoRectify)");
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.left_rotation_(i, j) = R1.at<double>(i, j);
  r.how_ = "rectified with cv::stereoRectify (alpha 0, zero disparity)";
  return r;
}

Rectifier Rectifier::from_settings(const SettingsFile& settings, const StereoCamera& camera) {
  Rectifier r;
  r.camera_ = camera;
  r.raw_width_ = *settings.left.width;
  r.raw_height_ = *settings.left.height;
  const cv::Size size(camera.width, camera.height);
  const auto build = [&](const RectificationSide& side, cv::Mat& map_x, cv::Mat& map_y) {
    const Eigen::Matrix3d new_k = side.P->leftCols<3>();
    opencv_step("rectification from the settings file's LEFT/RIGHT K, D, R, P", [&] {
      cv::initUndistortRectifyMap(to_cv(*side.K), distortion_to_cv(*side.D), to_cv(*side.R), to_cv(new_k), size,
                                  CV_32FC1, map_x, map_y);
    });
  };
  build(settings.left, r.left_map_x_, r.left_map_y_);
  build(settings.right, r.right_map_x_, r.right_map_y_);
  r.left_rotation_ =
      nearest_rotation(*settings.left.R, "LEFT.R of settings file " + in_quotes(settings.path));
  r.how_ = "rectified with the settings file's LEFT/RIGHT K, D, R, P";
  return r;
}

Rectifier Rectifier::undistort_only(const StereoCamera& camera, const std::vector<double>& D) {
  Rectifier r = identity(camera);
  const cv::Size size(camera.width, camera.height);
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  K(0, 0) = camera.fx;
  K(1, 1) = camera.fy;
  K(0, 2) = camera.cx;
  K(1, 2) = camera.cy;
  opencv_step("undistortion with the settings file's Camera.k1 k2 p1 p2 k3", [&] {
    cv::initUndistortRectifyMap(to_cv(K), distortion_to_cv(D), cv::Mat(), to_cv(K), size, CV_32FC1,
                                r.left_map_x_, r.left_map_y_);
  });
  r.right_map_x_ = r.left_map_x_;
  r.right_map_y_ = r.left_map_y_;
  r.how_ = "undistorted with the settings file's Camera.k1 k2 p1 p2 k3";
  return r;
}

Image Rectifier::apply(const cv::Mat& raw, int side) const {
  if (!remaps()) return to_image(raw);
  cv::Mat rectified;
  const cv::Mat& map_x = side == 0 ? left_map_x_ : right_map_x_;
  const cv::Mat& map_y = side == 0 ? left_map_y_ : right_map_y_;
  opencv_step("rectifying an image", [&] {
    cv::remap(raw, rectified, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  });
  return to_image(rectified);
}

}  // namespace porta::slam::detail
