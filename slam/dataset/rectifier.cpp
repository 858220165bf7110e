// Stereo rectification of the dataset readers (dataset_internal.hpp's Rectifier). A pair that is
// rectified already (rendered sequences, KITTI) passes through unchanged in every build; computing
// and applying remap tables (EuRoC's raw cameras, a settings file's LEFT/RIGHT block, lens
// undistortion) uses OpenCV's calib3d and imgproc, and a build without OpenCV (the GPU machine's)
// refuses those datasets with a message that says so.
#include <algorithm>
#include <cstring>

#include "dataset_internal.hpp"

#if PORTA_DATASET_HAVE_OPENCV
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#endif

namespace porta::slam::detail {

#if PORTA_DATASET_HAVE_OPENCV
struct Rectifier::RemapTables {
  cv::Mat left_x, left_y, right_x, right_y;
};
#else
struct Rectifier::RemapTables {};
#endif

namespace {

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

#if PORTA_DATASET_HAVE_OPENCV

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

#else

[[noreturn]] void needs_opencv(const std::string& what) {
  fail(what + " needs OpenCV (calib3d), and this build of PortaSLAM has none: rectify the images "
              "beforehand, or build with OpenCV (ci/setup.sh installs it)");
}

#endif

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

#if PORTA_DATASET_HAVE_OPENCV
  const cv::Size size(cam0.width, cam0.height);
  cv::Mat R1, R2, P1, P2, Q;
  auto tables = std::make_shared<RemapTables>();
  opencv_step("stereo rectification from the two cameras' calibration", [&] {
    cv::stereoRectify(to_cv(cam0.K), distortion_to_cv(cam0.D), to_cv(cam1.K), distortion_to_cv(cam1.D), size,
                      to_cv(R), to_cv(t), R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0, size);
    cv::initUndistortRectifyMap(to_cv(cam0.K), distortion_to_cv(cam0.D), R1, P1, size, CV_32FC1, tables->left_x,
                                tables->left_y);
    cv::initUndistortRectifyMap(to_cv(cam1.K), distortion_to_cv(cam1.D), R2, P2, size, CV_32FC1, tables->right_x,
                                tables->right_y);
  });
  r.tables_ = std::move(tables);
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
#else
  needs_opencv("stereo rectification of two cameras with distortion or not parallel");
#endif
}

Rectifier Rectifier::from_settings(const SettingsFile& settings, const StereoCamera& camera) {
#if PORTA_DATASET_HAVE_OPENCV
  Rectifier r;
  r.camera_ = camera;
  r.raw_width_ = *settings.left.width;
  r.raw_height_ = *settings.left.height;
  const cv::Size size(camera.width, camera.height);
  auto tables = std::make_shared<RemapTables>();
  const auto build = [&](const RectificationSide& side, cv::Mat& map_x, cv::Mat& map_y) {
    const Eigen::Matrix3d new_k = side.P->leftCols<3>();
    opencv_step("rectification from the settings file's LEFT/RIGHT K, D, R, P", [&] {
      cv::initUndistortRectifyMap(to_cv(*side.K), distortion_to_cv(*side.D), to_cv(*side.R), to_cv(new_k), size,
                                  CV_32FC1, map_x, map_y);
    });
  };
  build(settings.left, tables->left_x, tables->left_y);
  build(settings.right, tables->right_x, tables->right_y);
  r.tables_ = std::move(tables);
  r.left_rotation_ =
      nearest_rotation(*settings.left.R, "LEFT.R of settings file " + in_quotes(settings.path));
  r.how_ = "rectified with the settings file's LEFT/RIGHT K, D, R, P";
  return r;
#else
  (void)camera;
  needs_opencv("rectification with the LEFT/RIGHT block of settings file " + in_quotes(settings.path));
#endif
}

Rectifier Rectifier::undistort_only(const StereoCamera& camera, const std::vector<double>& D) {
  Rectifier r = identity(camera);
#if PORTA_DATASET_HAVE_OPENCV
  const cv::Size size(camera.width, camera.height);
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  K(0, 0) = camera.fx;
  K(1, 1) = camera.fy;
  K(0, 2) = camera.cx;
  K(1, 2) = camera.cy;
  auto tables = std::make_shared<RemapTables>();
  opencv_step("undistortion with the settings file's Camera.k1 k2 p1 p2 k3", [&] {
    cv::initUndistortRectifyMap(to_cv(K), distortion_to_cv(D), cv::Mat(), to_cv(K), size, CV_32FC1, tables->left_x,
                                tables->left_y);
  });
  tables->right_x = tables->left_x;
  tables->right_y = tables->left_y;
  r.tables_ = std::move(tables);
  r.how_ = "undistorted with the settings file's Camera.k1 k2 p1 p2 k3";
  return r;
#else
  (void)D;
  needs_opencv("undistortion with the settings file's Camera.k1 k2 p1 p2 k3");
#endif
}

Image Rectifier::apply(Image raw, int side) const {
  if (!remaps()) return raw;
#if PORTA_DATASET_HAVE_OPENCV
  const cv::Mat view(raw.height(), raw.width(), CV_8UC1, raw.data(), static_cast<std::size_t>(raw.pitch_bytes()));
  cv::Mat rectified;
  const cv::Mat& map_x = side == 0 ? tables_->left_x : tables_->right_x;
  const cv::Mat& map_y = side == 0 ? tables_->left_y : tables_->right_y;
  opencv_step("rectifying an image", [&] {
    cv::remap(view, rectified, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  });
  Image out(rectified.cols, rectified.rows);
  for (int y = 0; y < rectified.rows; ++y)
    std::memcpy(out.row(y), rectified.ptr<std::uint8_t>(y), static_cast<std::size_t>(rectified.cols));
  return out;
#else
  (void)side;
  return raw;  // unreachable: without OpenCV no Rectifier has remap tables
#endif
}

}  // namespace porta::slam::detail
