// EuRoC ASL reader: the real V1_01 head (rectification checked by feature matching, ground truth of
// the rectified camera), a synthetic sequence in the ASL layout, ORB-SLAM2 settings rectification,
// and every kind of bad input.
#if PORTA_DATASET_BUILT

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "porta/slam/dataset.hpp"
#include "dataset_test_files.hpp"
#include "support/data_path.hpp"

namespace porta::slam {
namespace {

namespace fs = std::filesystem;
using test_files::random_image;
using test_files::TempDir;
using test_files::write_text;

const fs::path kSettingsDir = fs::path(__FILE__).parent_path().parent_path().parent_path() / "settings";

std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (auto at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
    text.replace(at, from.size(), to);
  return text;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string list(const std::vector<double>& values) {
  std::string text = "[";
  char buffer[64];
  for (std::size_t i = 0; i < values.size(); ++i) {
    // 12 digits, as the renderer writes them: the rotation between the cameras is then I only up to
    // rounding, which the reader must still take for "already rectified".
    std::snprintf(buffer, sizeof buffer, "%s%.12g", i ? ", " : "", values[i]);
    text += buffer;
  }
  return text + "]";
}

std::string sensor_yaml(const SE3& body_cam, int width, int height, const std::vector<double>& intrinsics) {
  std::vector<double> t;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) t.push_back(body_cam.matrix()(r, c));
  return "%YAML:1.0\nsensor_type: camera\ncomment: synthetic\nT_BS:\n  cols: 4\n  rows: 4\n  data: " +
         list(t) + "\nrate_hz: 20\nresolution: [" + std::to_string(width) + ", " + std::to_string(height) +
         "]\ncamera_model: pinhole\nintrinsics: " + list(intrinsics) +
         " #fu, fv, cu, cv\ndistortion_model: radial-tangential\ndistortion_coefficients: [0.0, 0.0, 0.0, "
         "0.0]\n";
}

/// A synthetic sequence exactly as the renderer writes it: no distortion, cam1 = cam0 moved by the
/// baseline along cam0's x, body poses in state_groundtruth_estimate0/data.csv.
struct EurocSpec {
  int width = 80, height = 60, frames = 6;
  std::vector<double> intrinsics = {400.0, 401.0, 39.5, 29.25};
  double baseline = 0.11;
  SE3 body_cam0 = SE3::Identity();
  std::vector<std::int64_t> ns;
  std::vector<SE3> body_poses;
};

EurocSpec write_euroc(const fs::path& root) {
  EurocSpec spec;
  spec.body_cam0.linear() =
      Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  spec.body_cam0.translation() = Eigen::Vector3d(-0.02, -0.06, 0.01);
  SE3 shift = SE3::Identity();
  shift.translation().x() = spec.baseline;
  const SE3 body_cam1 = spec.body_cam0 * shift;
  const fs::path mav0 = root / "mav0";
  write_text(mav0 / "cam0" / "sensor.yaml",
             sensor_yaml(spec.body_cam0, spec.width, spec.height, spec.intrinsics));
  write_text(mav0 / "cam1" / "sensor.yaml", sensor_yaml(body_cam1, spec.width, spec.height, spec.intrinsics));
  std::string csv = "#timestamp [ns],filename\n";
  std::string gt =
      "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n";
  fs::create_directories(mav0 / "cam0" / "data");
  fs::create_directories(mav0 / "cam1" / "data");
  for (int i = 0; i < spec.frames; ++i) {
    const std::int64_t ns = 1403715273262142976LL + 50000000LL * i + (i % 2) * 128;
    spec.ns.push_back(ns);
    const std::string name = std::to_string(ns) + ".png";
    csv += std::to_string(ns) + "," + name + "\n";
    cv::imwrite((mav0 / "cam0" / "data" / name).string(), random_image(spec.width, spec.height, 2u * i));
    cv::imwrite((mav0 / "cam1" / "data" / name).string(), random_image(spec.width, spec.height, 2u * i + 1));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d(0.0, 0.6, 0.8)));
    const Eigen::Vector3d p(1.0 + 0.1 * i, 2.0 - 0.05 * i, 0.9 + 0.01 * i);
    SE3 body = SE3::Identity();
    body.linear() = q.toRotationMatrix();
    body.translation() = p;
    spec.body_poses.push_back(body);
    char line[256];
    std::snprintf(line, sizeof line, "%lld,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n",
                  static_cast<long long>(ns), p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z());
    gt += line;
  }
  write_text(mav0 / "cam0" / "data.csv", csv);
  write_text(mav0 / "cam1" / "data.csv", csv);
  write_text(mav0 / "state_groundtruth_estimate0" / "data.csv", gt);
  return spec;
}

bool same_pixels(const Image& image, const cv::Mat& expected) {
  if (image.width() != expected.cols || image.height() != expected.rows) return false;
  for (int y = 0; y < expected.rows; ++y)
    for (int x = 0; x < expected.cols; ++x)
      if (image.at(x, y) != expected.at<std::uint8_t>(y, x)) return false;
  return true;
}

cv::Mat as_mat(const Image& image) {
  return cv::Mat(image.height(), image.width(), CV_8UC1, const_cast<std::uint8_t*>(image.data()),
                 static_cast<std::size_t>(image.pitch_bytes()))
      .clone();
}

template <typename F>
std::string error_of(F&& open) {
  try {
    open();
  } catch (const DatasetError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected DatasetError, got another exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected DatasetError, nothing was thrown";
  return {};
}

/// Row misalignment of a stereo pair: ORB matches (OpenCV, cross-checked), |y_left - y_right| of
/// those that are plausible (|dy| < 20 px, disparity > -5 px).
struct RowError {
  std::size_t matches = 0;
  double median_dy = 0.0;
  double fraction_below_1px = 0.0;
  double mean_signed_dy = 0.0;  ///< of the matches within 3 px: a vertical shift left by rectification
};

RowError row_error(const cv::Mat& left, const cv::Mat& right) {
  const auto orb = cv::ORB::create(1500);
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  orb->detectAndCompute(left, cv::noArray(), kl, dl);
  orb->detectAndCompute(right, cv::noArray(), kr, dr);
  std::vector<cv::DMatch> matches;
  cv::BFMatcher(cv::NORM_HAMMING, true).match(dl, dr, matches);
  std::vector<double> dy;
  double signed_sum = 0.0;
  int signed_count = 0;
  for (const auto& m : matches) {
    const cv::Point2f a = kl[static_cast<std::size_t>(m.queryIdx)].pt,
                      b = kr[static_cast<std::size_t>(m.trainIdx)].pt;
    const double d = std::abs(a.y - b.y);
    if (d < 20.0 && a.x - b.x > -5.0) dy.push_back(d);
    if (d < 3.0 && a.x - b.x > -5.0) {
      signed_sum += a.y - b.y;
      ++signed_count;
    }
  }
  RowError e;
  e.mean_signed_dy = signed_count ? signed_sum / signed_count : 0.0;
  e.matches = dy.size();
  if (dy.empty()) return e;
  std::sort(dy.begin(), dy.end());
  e.median_dy = dy[dy.size() / 2];
  e.fraction_below_1px =
      static_cast<double>(std::count_if(dy.begin(), dy.end(), [](double d) { return d < 1.0; })) / dy.size();
  return e;
}

// ---- The real V1_01 head -------------------------------------------------------------------------

TEST(DatasetEuroc, RealSequenceOpensWith24RectifiedPairs) {
  const fs::path path = porta::test::data_file("euroc-v101-head");
  if (path.empty()) GTEST_SKIP() << porta::test::skip_reason("euroc-v101-head");
  const auto dataset = open_dataset(DatasetKind::euroc, path.string());
  ASSERT_EQ(dataset->size(), 24u);
  const StereoCamera& camera = dataset->camera();
  EXPECT_EQ(camera.width, 752);
  EXPECT_EQ(camera.height, 480);
  // cam0 and cam1 are 11.0 cm apart (|t| of T_cam1_cam0 = 0.110078 m).
  EXPECT_NEAR(camera.baseline_m, 0.11008, 2e-4);
  EXPECT_EQ(camera.fx, camera.fy);  // stereoRectify gives square pixels
  EXPECT_GT(camera.fx, 400.0);
  EXPECT_LT(camera.fx, 460.0);
  EXPECT_DOUBLE_EQ(dataset->time_s(0), 1403715273262142976.0 / 1e9);
  EXPECT_NEAR(dataset->time_s(23) - dataset->time_s(0), 23 * 0.05, 1e-5);
  EXPECT_NE(dataset->describe().find("24 stereo frames"), std::string::npos) << dataset->describe();

  const StereoPair pair = dataset->load(0);
  EXPECT_EQ(pair.left.width(), 752);
  EXPECT_EQ(pair.left.height(), 480);
  EXPECT_EQ(pair.right.width(), 752);
  // alpha 0: no black (unseen) border in the rectified image.
  const cv::Mat left = as_mat(pair.left);
  for (const cv::Point p :
       {cv::Point(0, 0), cv::Point(751, 0), cv::Point(0, 479), cv::Point(751, 479), cv::Point(0, 240)})
    EXPECT_GT(left.at<std::uint8_t>(p), 0) << p;
  // The same path given as the mav0 folder itself.
  const auto from_mav0 = open_dataset(DatasetKind::euroc, (path / "mav0").string());
  EXPECT_EQ(from_mav0->size(), 24u);
  EXPECT_EQ(from_mav0->camera().fx, camera.fx);
}

TEST(DatasetEuroc, RealRectifiedPairsHaveMatchesOnTheSameRowUnlikeTheRawImages) {
  const fs::path path = porta::test::data_file("euroc-v101-head");
  if (path.empty()) GTEST_SKIP() << porta::test::skip_reason("euroc-v101-head");
  const auto dataset = open_dataset(DatasetKind::euroc, path.string());
  for (std::size_t index : {std::size_t{0}, std::size_t{12}, std::size_t{23}}) {
    const StereoPair pair = dataset->load(index);
    const RowError rectified = row_error(as_mat(pair.left), as_mat(pair.right));
    // The raw files of the same pair: row `index` of cam0/data.csv (the pairs all match here).
    std::ifstream csv(path / "mav0" / "cam0" / "data.csv");
    std::string line, file;
    for (std::size_t row = 0; std::getline(csv, line);) {
      if (line.empty() || line[0] == '#') continue;
      if (row++ == index) file = line.substr(line.find(',') + 1);
    }
    file.erase(file.find_last_not_of("\r\n ") + 1);
    const cv::Mat raw_left =
        cv::imread((path / "mav0" / "cam0" / "data" / file).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat raw_right =
        cv::imread((path / "mav0" / "cam1" / "data" / file).string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(raw_left.empty());
    ASSERT_FALSE(raw_right.empty());
    const RowError raw = row_error(raw_left, raw_right);
    SCOPED_TRACE(
        "pair " + std::to_string(index) + ": rectified median |dy| " + std::to_string(rectified.median_dy) +
        " px, " + std::to_string(rectified.fraction_below_1px) + " below 1 px of " +
        std::to_string(rectified.matches) + "; raw median " + std::to_string(raw.median_dy) + " px, " +
        std::to_string(raw.fraction_below_1px) + " below 1 px of " + std::to_string(raw.matches));
    std::cout << "[ info     ] EuRoC pair " << index << ": rectified median |dy| " << rectified.median_dy
              << " px, " << rectified.fraction_below_1px << " of " << rectified.matches
              << " matches below 1 px; raw median " << raw.median_dy << " px, " << raw.fraction_below_1px
              << " of " << raw.matches << " below 1 px; rectified mean signed dy " << rectified.mean_signed_dy
              << " px\n";
    EXPECT_GT(rectified.matches, 150u);
    EXPECT_LT(rectified.median_dy, 0.5);
    EXPECT_GT(rectified.fraction_below_1px, 0.7);
    EXPECT_LT(std::abs(rectified.mean_signed_dy), 0.25);
    EXPECT_GT(raw.median_dy, 2.0 * rectified.median_dy);
    EXPECT_LT(raw.fraction_below_1px, rectified.fraction_below_1px - 0.1);
  }
}

TEST(DatasetEuroc, RealGroundTruthIsOfTheRectifiedLeftCameraAndStandsStill) {
  const fs::path path = porta::test::data_file("euroc-v101-head");
  if (path.empty()) GTEST_SKIP() << porta::test::skip_reason("euroc-v101-head");
  const auto dataset = open_dataset(DatasetKind::euroc, path.string());
  ASSERT_TRUE(dataset->ground_truth().has_value());
  const Trajectory& gt = *dataset->ground_truth();
  ASSERT_EQ(gt.size(), 23u);  // groundtruth_tum.txt ends one frame before the images
  double largest_move = 0.0;
  for (const auto& a : gt.poses)
    for (const auto& b : gt.poses)
      largest_move = std::max(largest_move, (a.pose.translation() - b.pose.translation()).norm());
  EXPECT_LE(largest_move, 0.003);
  // Each ground-truth time is within 10 us of a frame time (the TUM file rounds to 10 us).
  for (std::size_t i = 0; i < gt.size(); ++i) EXPECT_NEAR(gt.poses[i].time_s, dataset->time_s(i), 1e-5);

  // The camera is 6.8 cm from the body (T_BS of cam0) and looks along body +z (the third column of
  // cam0's T_BS rotation is about (0, 0, 1)): check against the raw body pose of the TUM file.
  const Eigen::Vector3d first_body(0.878895, 2.183400, 0.948427);  // line 1 of groundtruth_tum.txt
  EXPECT_NEAR((gt.poses[0].pose.translation() - first_body).norm(), 0.0684, 0.003);
  const Eigen::Quaterniond q_body(0.069433, -0.824237, -0.106942, -0.551702);  // qw qx qy qz
  const Eigen::Matrix3d r_body = q_body.normalized().toRotationMatrix();
  const Eigen::Vector3d optical_axis_world = gt.poses[0].pose.linear().col(2);
  EXPECT_GT(optical_axis_world.dot(r_body.col(2)), 0.99);
}

TEST(DatasetEuroc, SettingsFileRectificationGivesItsCameraAndTheSameImages) {
  const fs::path path = porta::test::data_file("euroc-v101-head");
  if (path.empty()) GTEST_SKIP() << porta::test::skip_reason("euroc-v101-head");
  const auto computed = open_dataset(DatasetKind::euroc, path.string());
  DatasetOptions options;
  options.settings_path = (kSettingsDir / "EuRoC.yaml").string();
  const auto from_settings = open_dataset(DatasetKind::euroc, path.string(), options);
  EXPECT_EQ(from_settings->camera().fx, 436.23458640269558);
  EXPECT_EQ(from_settings->camera().cx, 364.44123458862305);
  EXPECT_NEAR(from_settings->camera().baseline_m, 48.019761960624088 / 436.23458640269558, 1e-15);
  // settings/EuRoC.yaml holds what the reader computes itself.
  EXPECT_NEAR(computed->camera().fx, from_settings->camera().fx, 1e-6);
  EXPECT_NEAR(computed->camera().cy, from_settings->camera().cy, 1e-6);
  EXPECT_NEAR(computed->camera().baseline_m, from_settings->camera().baseline_m, 1e-6);
  EXPECT_NE(from_settings->describe().find("settings file"), std::string::npos) << from_settings->describe();
  const StereoPair a = computed->load(5), b = from_settings->load(5);
  cv::Mat diff;
  cv::absdiff(as_mat(a.left), as_mat(b.left), diff);
  EXPECT_LT(cv::mean(diff)[0], 0.05);
  cv::absdiff(as_mat(a.right), as_mat(b.right), diff);
  EXPECT_LT(cv::mean(diff)[0], 0.05);
  ASSERT_TRUE(from_settings->ground_truth().has_value());
  EXPECT_LT((from_settings->ground_truth()->poses[3].pose.matrix() -
             computed->ground_truth()->poses[3].pose.matrix())
                .cwiseAbs()
                .maxCoeff(),
            1e-6);
}

// ---- A synthetic sequence in the ASL layout ------------------------------------------------------

TEST(DatasetEuroc, SyntheticRectifiedSequenceKeepsTheExactCameraPixelsAndPoses) {
  TempDir dir;
  const EurocSpec spec = write_euroc(dir.path());
  const auto dataset = open_dataset(DatasetKind::euroc, dir.path().string());
  ASSERT_EQ(dataset->size(), static_cast<std::size_t>(spec.frames));
  const StereoCamera& camera = dataset->camera();
  EXPECT_EQ(camera.width, spec.width);
  EXPECT_EQ(camera.height, spec.height);
  EXPECT_EQ(camera.fx, spec.intrinsics[0]);
  EXPECT_EQ(camera.fy, spec.intrinsics[1]);
  EXPECT_EQ(camera.cx, spec.intrinsics[2]);
  EXPECT_EQ(camera.cy, spec.intrinsics[3]);
  EXPECT_NEAR(camera.baseline_m, spec.baseline, 1e-11);
  EXPECT_NE(dataset->describe().find("already rectified"), std::string::npos) << dataset->describe();
  ASSERT_TRUE(dataset->ground_truth().has_value());
  const Trajectory& gt = *dataset->ground_truth();
  ASSERT_EQ(gt.size(), spec.body_poses.size());
  for (std::size_t i = 0; i < gt.size(); ++i) {
    EXPECT_DOUBLE_EQ(dataset->time_s(i), static_cast<double>(spec.ns[i]) / 1e9);
    EXPECT_DOUBLE_EQ(gt.poses[i].time_s, dataset->time_s(i));
    const SE3 expected = spec.body_poses[i] * spec.body_cam0;  // rectified left camera = cam0 here
    EXPECT_LT((gt.poses[i].pose.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-10) << i;
  }
  for (std::size_t i = 0; i < dataset->size(); ++i) {
    const StereoPair pair = dataset->load(i);
    EXPECT_TRUE(same_pixels(pair.left, random_image(spec.width, spec.height, 2u * static_cast<unsigned>(i))));
    EXPECT_TRUE(
        same_pixels(pair.right, random_image(spec.width, spec.height, 2u * static_cast<unsigned>(i) + 1)));
  }
}

TEST(DatasetEuroc, SyntheticSequenceAcceptsSensorFilesWithoutTheYamlDirective) {
  TempDir dir;
  write_euroc(dir.path());
  for (const char* cam : {"cam0", "cam1"}) {
    const fs::path file = dir.path() / "mav0" / cam / "sensor.yaml";
    write_text(file, replace_all(read_text(file), "%YAML:1.0\n", ""));
  }
  EXPECT_EQ(open_dataset(DatasetKind::euroc, dir.path().string())->size(), 6u);
}

TEST(DatasetEuroc, FramesOfOneCameraOnlyAreDroppedAndCounted) {
  TempDir dir;
  const EurocSpec spec = write_euroc(dir.path());
  // cam1 misses frame 2 and has an extra frame.
  std::string csv = "#timestamp [ns],filename\n";
  for (int i = 0; i < spec.frames; ++i)
    if (i != 2)
      csv += std::to_string(spec.ns[static_cast<std::size_t>(i)]) + "," +
             std::to_string(spec.ns[static_cast<std::size_t>(i)]) + ".png\n";
  csv += "1403715299000000000,extra.png\n";
  cv::imwrite((dir.path() / "mav0" / "cam1" / "data" / "extra.png").string(), random_image(80, 60, 99));
  write_text(dir.path() / "mav0" / "cam1" / "data.csv", csv);
  const auto dataset = open_dataset(DatasetKind::euroc, dir.path().string());
  EXPECT_EQ(dataset->size(), 5u);
  EXPECT_DOUBLE_EQ(dataset->time_s(2), static_cast<double>(spec.ns[3]) / 1e9);
  EXPECT_NE(dataset->describe().find("dropped 1 cam0 and 1 cam1 images"), std::string::npos)
      << dataset->describe();
}

TEST(DatasetEuroc, LeftOnlyReadsCam0AloneWithTheStereoCalibration) {
  TempDir dir;
  const EurocSpec spec = write_euroc(dir.path());
  DatasetOptions options;
  options.left_only = true;
  const auto dataset = open_dataset(DatasetKind::euroc, dir.path().string(), options);
  EXPECT_FALSE(dataset->has_right());
  EXPECT_NEAR(dataset->camera().baseline_m, spec.baseline, 1e-11);
  const StereoPair pair = dataset->load(1);
  EXPECT_TRUE(same_pixels(pair.left, random_image(spec.width, spec.height, 2u)));
  EXPECT_TRUE(pair.right.empty());
}

// ---- Bad input -----------------------------------------------------------------------------------

TEST(DatasetEuroc, MissingFoldersAreNamed) {
  TempDir dir;
  std::string message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("has no mav0 folder"), std::string::npos) << message;
  write_euroc(dir.path());
  fs::remove_all(dir.path() / "mav0" / "cam1");
  message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("has no cam1 folder (right camera)"), std::string::npos) << message;
  fs::create_directories(dir.path() / "mav0" / "cam1");
  fs::copy_file(dir.path() / "mav0" / "cam0" / "sensor.yaml", dir.path() / "mav0" / "cam1" / "sensor.yaml");
  message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("cam1' has no data.csv"), std::string::npos) << message;
  fs::remove_all(dir.path() / "mav0" / "cam0" / "data");
  message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("cam0' has no data/ image folder"), std::string::npos) << message;
  message = error_of([&] { open_dataset(DatasetKind::euroc, (dir.path() / "missing").string()); });
  EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
}

TEST(DatasetEuroc, UnparsableImageListLineNamesFileAndLine) {
  TempDir dir;
  write_euroc(dir.path());
  const fs::path csv = dir.path() / "mav0" / "cam1" / "data.csv";
  std::string text = read_text(csv);
  text.insert(text.find('\n', text.find('\n', text.find('\n') + 1) + 1) + 1, "14037152732621X,bad.png\n");
  write_text(csv, text);
  std::string message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("cam1/data.csv' line 4"), std::string::npos) << message;
  EXPECT_NE(message.find("not a timestamp"), std::string::npos) << message;
  write_text(csv, "#timestamp [ns],filename\n1403715273262142976 1403715273262142976.png\n");
  message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("line 2: expected 'timestamp_ns,filename'"), std::string::npos) << message;
  write_text(csv, "#timestamp [ns],filename\n");
  message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("lists no images"), std::string::npos) << message;
}

TEST(DatasetEuroc, NoCommonTimestampIsAnError) {
  TempDir dir;
  write_euroc(dir.path());
  write_text(dir.path() / "mav0" / "cam1" / "data.csv", "#timestamp [ns],filename\n17,a.png\n18,b.png\n");
  const std::string message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("no cam0 image has a cam1 image of the same timestamp"), std::string::npos)
      << message;
}

TEST(DatasetEuroc, BadSensorFilesNameFileAndKey) {
  TempDir dir;
  write_euroc(dir.path());
  const fs::path sensor = dir.path() / "mav0" / "cam1" / "sensor.yaml";
  const std::string good = read_text(sensor);
  const auto message_for = [&](const std::string& content) {
    write_text(sensor, content);
    return error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  };
  std::string message = message_for(replace_all(good, "intrinsics:", "intrinsic_values:"));
  EXPECT_NE(message.find("cam1/sensor.yaml': key 'intrinsics' is missing"), std::string::npos) << message;
  message = message_for(replace_all(good, "resolution: [80, 60]", "resolution: [80]"));
  EXPECT_NE(message.find("key 'resolution' has 1 numbers, expected 2"), std::string::npos) << message;
  message =
      message_for(replace_all(good, "distortion_model: radial-tangential", "distortion_model: equidistant"));
  EXPECT_NE(message.find("'equidistant'"), std::string::npos) << message;
  message = message_for(replace_all(good, "T_BS:", "T_XY:"));
  EXPECT_NE(message.find("key 'T_BS' is missing"), std::string::npos) << message;
  message = message_for(replace_all(good, "data: [", "data: [3.0, "));
  EXPECT_NE(message.find("key 'T_BS' has 17 numbers"), std::string::npos) << message;
  message = message_for("%YAML:1.0\nintrinsics: [1, 2\n");
  EXPECT_NE(message.find("cam1/sensor.yaml': not valid YAML: line 2"), std::string::npos) << message;
  fs::remove(sensor);
  message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("cam1/sensor.yaml': no such file"), std::string::npos) << message;
}

TEST(DatasetEuroc, NonRigidBodyTransformIsAnError) {
  TempDir dir;
  const EurocSpec spec = write_euroc(dir.path());
  SE3 scaled = spec.body_cam0;
  scaled.linear() *= 1.5;
  write_text(dir.path() / "mav0" / "cam0" / "sensor.yaml", sensor_yaml(scaled, 80, 60, spec.intrinsics));
  const std::string message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find("T_BS"), std::string::npos) << message;
  EXPECT_NE(message.find("is not a rotation"), std::string::npos) << message;
}

TEST(DatasetEuroc, MissingCorruptOrWrongSizedImagesAreNamed) {
  TempDir dir;
  const EurocSpec spec = write_euroc(dir.path());
  const fs::path data0 = dir.path() / "mav0" / "cam0" / "data";
  const std::string name = [&](std::size_t i) { return std::to_string(spec.ns[i]) + ".png"; }(4);
  fs::remove(data0 / name);
  std::string message = error_of([&] { open_dataset(DatasetKind::euroc, dir.path().string()); });
  EXPECT_NE(message.find(name + "' listed in cam0/data.csv is missing"), std::string::npos) << message;
  write_text(data0 / name, "garbage");
  const std::string other = std::to_string(spec.ns[1]) + ".png";
  cv::imwrite((dir.path() / "mav0" / "cam1" / "data" / other).string(), random_image(80, 50, 3));
  const auto dataset = open_dataset(DatasetKind::euroc, dir.path().string());
  message = error_of([&] { dataset->load(4); });
  EXPECT_NE(message.find("cannot decode image"), std::string::npos) << message;
  EXPECT_NE(message.find(name), std::string::npos) << message;
  message = error_of([&] { dataset->load(1); });
  EXPECT_NE(message.find("cam1/data/" + other + "' is 80x50, expected 80x60"), std::string::npos) << message;
  message = error_of([&] { dataset->load(6); });
  EXPECT_NE(message.find("frame index 6 is out of range"), std::string::npos) << message;
}

}  // namespace
}  // namespace porta::slam

#endif  // PORTA_DATASET_BUILT
