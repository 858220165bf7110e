// Generic stereo folder reader (left/ + right/ + an ORB-SLAM2 settings file), and the dataset-kind
// names.
#if PORTA_DATASET_BUILT

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "porta/slam/dataset.hpp"
#include "dataset_test_files.hpp"

namespace porta::slam {
namespace {

namespace fs = std::filesystem;
using test_files::random_image;
using test_files::TempDir;
using test_files::write_text;

const char* const kSettings =
    "%YAML:1.0\nCamera.fx: 300.0\nCamera.fy: 300.0\nCamera.cx: 35.5\nCamera.cy: 23.5\nCamera.bf: 36.0\n"
    "Camera.width: 72\nCamera.height: 48\nCamera.fps: 25.0\n";

/// left/ and right/ with 4 pairs (frame_0.png ..), the settings file beside them.
DatasetOptions write_folder(const fs::path& root, const char* left = "left", const char* right = "right") {
  for (int i = 0; i < 4; ++i) {
    const std::string name = "frame_" + std::to_string(i) + ".png";
    fs::create_directories(root / left);
    fs::create_directories(root / right);
    cv::imwrite((root / left / name).string(), random_image(72, 48, 2u * i));
    // A color image on the right: converted to gray like the portaslam program does.
    cv::Mat color;
    cv::merge(std::vector<cv::Mat>{random_image(72, 48, 2u * i + 1), random_image(72, 48, 7),
                                   random_image(72, 48, 8)},
              color);
    cv::imwrite((root / right / name).string(), color);
  }
  write_text(root / "settings.yaml", kSettings);
  DatasetOptions options;
  options.settings_path = (root / "settings.yaml").string();
  return options;
}

bool same_pixels(const Image& image, const cv::Mat& expected) {
  if (image.width() != expected.cols || image.height() != expected.rows) return false;
  for (int y = 0; y < expected.rows; ++y)
    for (int x = 0; x < expected.cols; ++x)
      if (image.at(x, y) != expected.at<std::uint8_t>(y, x)) return false;
  return true;
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

TEST(DatasetKind, NamesRoundTrip) {
  for (DatasetKind kind : {DatasetKind::kitti, DatasetKind::euroc, DatasetKind::folder})
    EXPECT_EQ(parse_dataset_kind(to_string(kind)), kind);
  EXPECT_FALSE(parse_dataset_kind("KITTI").has_value());
  EXPECT_FALSE(parse_dataset_kind("tum").has_value());
  EXPECT_FALSE(parse_dataset_kind("").has_value());
}

TEST(DatasetFolder, LoadsPairsWithTheSettingsCameraAndFpsTimes) {
  TempDir dir;
  const DatasetOptions options = write_folder(dir.path());
  const auto dataset = open_dataset(DatasetKind::folder, dir.path().string(), options);
  ASSERT_EQ(dataset->size(), 4u);
  const StereoCamera& camera = dataset->camera();
  EXPECT_EQ(camera.width, 72);
  EXPECT_EQ(camera.height, 48);
  EXPECT_EQ(camera.fx, 300.0);
  EXPECT_EQ(camera.cx, 35.5);
  EXPECT_DOUBLE_EQ(camera.baseline_m, 0.12);
  EXPECT_DOUBLE_EQ(dataset->time_s(2), 2.0 / 25.0);
  EXPECT_FALSE(dataset->ground_truth().has_value());
  const StereoPair pair = dataset->load(3);
  EXPECT_TRUE(same_pixels(pair.left, random_image(72, 48, 6)));
  cv::Mat color = cv::imread((dir.path() / "right" / "frame_3.png").string(), cv::IMREAD_COLOR), gray;
  cv::cvtColor(color, gray, cv::COLOR_BGR2GRAY);
  EXPECT_TRUE(same_pixels(pair.right, gray));
  EXPECT_NE(dataset->describe().find("times from Camera.fps"), std::string::npos) << dataset->describe();
}

TEST(DatasetFolder, AcceptsKittiAndEurocFolderNamesTimesAndGroundTruth) {
  TempDir dir;
  DatasetOptions options = write_folder(dir.path(), "cam0", "cam1");
  write_text(dir.path() / "times.txt", "10.0\n10.5\n11.0\n11.5\n");
  write_text(dir.path() / "gt.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n");
  options.ground_truth_path = (dir.path() / "gt.txt").string();
  const auto dataset = open_dataset(DatasetKind::folder, dir.path().string(), options);
  EXPECT_EQ(dataset->size(), 4u);
  EXPECT_DOUBLE_EQ(dataset->time_s(1), 10.5);
  ASSERT_TRUE(dataset->ground_truth().has_value());
  ASSERT_EQ(dataset->ground_truth()->size(), 2u);
  EXPECT_DOUBLE_EQ(dataset->ground_truth()->poses[1].time_s, 10.5);
  EXPECT_DOUBLE_EQ(dataset->ground_truth()->poses[1].pose.translation().x(), 1.0);
}

TEST(DatasetFolder, LeftOnlyNeedsNoRightFolder) {
  TempDir dir;
  DatasetOptions options = write_folder(dir.path());
  fs::remove_all(dir.path() / "right");
  std::string message = error_of([&] { open_dataset(DatasetKind::folder, dir.path().string(), options); });
  EXPECT_NE(message.find("no right folder (right camera)"), std::string::npos) << message;
  options.left_only = true;
  const auto dataset = open_dataset(DatasetKind::folder, dir.path().string(), options);
  EXPECT_FALSE(dataset->has_right());
  EXPECT_TRUE(dataset->load(0).right.empty());
}

TEST(DatasetFolder, DistortionInTheSettingsFileIsUndistorted) {
  TempDir dir;
  DatasetOptions options = write_folder(dir.path());
  write_text(dir.path() / "settings.yaml", std::string(kSettings) + "Camera.k1: -0.2\nCamera.k2: 0.05\n");
  const auto dataset = open_dataset(DatasetKind::folder, dir.path().string(), options);
  EXPECT_NE(dataset->describe().find("undistorted"), std::string::npos) << dataset->describe();
  const StereoPair pair = dataset->load(0);
  EXPECT_EQ(pair.left.width(), 72);
  EXPECT_FALSE(same_pixels(pair.left, random_image(72, 48, 0)));
  // The principal point does not move.
  EXPECT_EQ(pair.left.at(35, 23), random_image(72, 48, 0).at<std::uint8_t>(23, 35));
}

TEST(DatasetFolder, BadInputIsNamed) {
  TempDir dir;
  DatasetOptions options = write_folder(dir.path());
  std::string message = error_of([&] { open_dataset(DatasetKind::folder, dir.path().string()); });
  EXPECT_NE(message.find("needs a settings file"), std::string::npos) << message;

  DatasetOptions missing_settings = options;
  missing_settings.settings_path = (dir.path() / "nope.yaml").string();
  message = error_of([&] { open_dataset(DatasetKind::folder, dir.path().string(), missing_settings); });
  EXPECT_NE(message.find("nope.yaml': no such file"), std::string::npos) << message;

  write_text(dir.path() / "settings.yaml", "%YAML:1.0\nCamera.fx: 300.0\n");
  message = error_of([&] { open_dataset(DatasetKind::folder, dir.path().string(), options); });
  EXPECT_NE(message.find("key 'Camera.fy' is missing"), std::string::npos) << message;
  write_text(dir.path() / "settings.yaml", kSettings);

  write_text(dir.path() / "times.txt", "0\n1\n");
  message = error_of([&] { open_dataset(DatasetKind::folder, dir.path().string(), options); });
  EXPECT_NE(message.find("has 2 times but"), std::string::npos) << message;
  fs::remove(dir.path() / "times.txt");

  fs::rename(dir.path() / "right" / "frame_2.png", dir.path() / "right" / "frame_2b.png");
  message = error_of([&] { open_dataset(DatasetKind::folder, dir.path().string(), options); });
  EXPECT_NE(message.find("names differ at position 2"), std::string::npos) << message;
  fs::rename(dir.path() / "right" / "frame_2b.png", dir.path() / "right" / "frame_2.png");

  cv::imwrite((dir.path() / "left" / "frame_1.png").string(), random_image(72, 40, 1));
  const auto dataset = open_dataset(DatasetKind::folder, dir.path().string(), options);
  message = error_of([&] { dataset->load(1); });
  EXPECT_NE(message.find("left/frame_1.png' is 72x40, expected 72x48"), std::string::npos) << message;
  message = error_of([&] { dataset->load(4); });
  EXPECT_NE(message.find("frame index 4 is out of range"), std::string::npos) << message;

  fs::remove_all(dir.path() / "left");
  fs::remove_all(dir.path() / "right");
  message = error_of([&] { open_dataset(DatasetKind::folder, dir.path().string(), options); });
  EXPECT_NE(message.find("has no left/ and right/ image folders"), std::string::npos) << message;
}

}  // namespace
}  // namespace porta::slam

#endif  // PORTA_DATASET_BUILT
