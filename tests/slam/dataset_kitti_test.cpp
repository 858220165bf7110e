// KITTI odometry reader: the real left-only sample, a synthetic stereo sequence in KITTI's layout, and
// every kind of bad input.
#if PORTA_DATASET_BUILT

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <thread>
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

std::string numbers(const std::vector<double>& values) {
  std::string text;
  char buffer[64];
  for (double v : values) {
    std::snprintf(buffer, sizeof buffer, "%s%.17g", text.empty() ? "" : " ", v);
    text += buffer;
  }
  return text;
}

/// What the synthetic sequence was written with.
struct KittiSpec {
  int width = 64, height = 48, frames = 5;
  double fx = 500.0, fy = 501.5, cx = 31.25, cy = 23.75, baseline = 0.54;
  std::vector<SE3> poses;
};

KittiSpec write_kitti(const fs::path& root, bool with_right = true) {
  KittiSpec spec;
  const std::vector<double> p0 = {spec.fx, 0, spec.cx, 0, 0, spec.fy, spec.cy, 0, 0, 0, 1, 0};
  const std::vector<double> p1 = {spec.fx, 0, spec.cx, -spec.fx * spec.baseline, 0, spec.fy, spec.cy, 0, 0,
                                  0,       1, 0};
  write_text(root / "calib.txt", "P0: " + numbers(p0) + "\nP1: " + numbers(p1) + "\nP2: " + numbers(p0) +
                                     "\nP3: " + numbers(p1) + "\n");
  std::string times, poses;
  for (int i = 0; i < spec.frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d.png", i);
    fs::create_directories(root / "image_0");
    cv::imwrite((root / "image_0" / name).string(), random_image(spec.width, spec.height, 2u * i));
    if (with_right) {
      fs::create_directories(root / "image_1");
      cv::imwrite((root / "image_1" / name).string(), random_image(spec.width, spec.height, 2u * i + 1));
    }
    times += numbers({0.1 * i + 0.003}) + "\n";
    SE3 pose = SE3::Identity();
    pose.linear() =
        Eigen::AngleAxisd(0.02 * i, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
    pose.translation() = Eigen::Vector3d(0.1 * i, -0.01 * i, 0.8 * i);
    spec.poses.push_back(pose);
    std::vector<double> row;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) row.push_back(pose.matrix()(r, c));
    poses += numbers(row) + "\n";
  }
  write_text(root / "times.txt", times);
  write_text(root / "poses.txt", poses);
  return spec;
}

bool same_pixels(const Image& image, const cv::Mat& expected) {
  if (image.width() != expected.cols || image.height() != expected.rows) return false;
  for (int y = 0; y < expected.rows; ++y)
    for (int x = 0; x < expected.cols; ++x)
      if (image.at(x, y) != expected.at<std::uint8_t>(y, x)) return false;
  return true;
}

/// Runs `open` and returns DatasetError's message (fails the test when nothing or something else is thrown).
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

// ---- The real sample -----------------------------------------------------------------------------

TEST(DatasetKitti, RealLeftOnlySampleLoadsImagesCameraTimesAndPoses) {
  const fs::path path = porta::test::data_file("kitti07-left-head");
  if (path.empty()) GTEST_SKIP() << porta::test::skip_reason("kitti07-left-head");
  DatasetOptions options;
  options.left_only = true;
  const auto dataset = open_dataset(DatasetKind::kitti, path.string(), options);
  EXPECT_FALSE(dataset->has_right());
  ASSERT_EQ(dataset->size(), 20u);
  const StereoCamera& camera = dataset->camera();
  EXPECT_EQ(camera.width, 1226);
  EXPECT_EQ(camera.height, 370);
  EXPECT_DOUBLE_EQ(camera.fx, 707.0912);
  EXPECT_DOUBLE_EQ(camera.fy, 707.0912);
  EXPECT_DOUBLE_EQ(camera.cx, 601.8873);
  EXPECT_DOUBLE_EQ(camera.cy, 183.1104);
  EXPECT_NEAR(camera.baseline_m, 379.8145 / 707.0912, 1e-12);
  EXPECT_DOUBLE_EQ(dataset->time_s(0), 0.0);
  EXPECT_DOUBLE_EQ(dataset->time_s(1), 0.1038752);
  for (std::size_t i = 1; i < dataset->size(); ++i) EXPECT_GT(dataset->time_s(i), dataset->time_s(i - 1));

  ASSERT_TRUE(dataset->ground_truth().has_value());
  const Trajectory& gt = *dataset->ground_truth();
  ASSERT_EQ(gt.size(), 20u);
  EXPECT_TRUE(gt.has_times);
  for (std::size_t i = 0; i < gt.size(); ++i) EXPECT_DOUBLE_EQ(gt.poses[i].time_s, dataset->time_s(i));
  EXPECT_LT((gt.poses[0].pose.translation()).norm(), 1e-9);
  // Second pose of poses.txt: translation (-0.004596714, -0.002001524, 0.09154274).
  EXPECT_NEAR(gt.poses[1].pose.translation().z(), 0.09154274, 1e-6);
  // The car starts slowly (about 1.6 m/s over these 2 s), forward along the camera's +z.
  const Eigen::Vector3d travel = gt.poses[19].pose.translation() - gt.poses[0].pose.translation();
  const double speed = travel.norm() / (gt.poses[19].time_s - gt.poses[0].time_s);
  EXPECT_GT(speed, 0.5);
  EXPECT_LT(speed, 30.0);
  EXPECT_GT(travel.z(), 0.9 * travel.norm());

  const StereoPair pair = dataset->load(7);
  EXPECT_EQ(pair.index, 7u);
  EXPECT_DOUBLE_EQ(pair.time_s, dataset->time_s(7));
  EXPECT_EQ(pair.left.width(), 1226);
  EXPECT_EQ(pair.left.height(), 370);
  EXPECT_TRUE(pair.right.empty());
  const cv::Mat expected = cv::imread((path / "image_0" / "000007.png").string(), cv::IMREAD_GRAYSCALE);
  EXPECT_TRUE(same_pixels(pair.left, expected));
  EXPECT_NE(dataset->describe().find("20 frames (left camera only)"), std::string::npos)
      << dataset->describe();
}

TEST(DatasetKitti, RealLeftOnlySampleOpenedAsStereoSaysTheRightCameraIsMissing) {
  const fs::path path = porta::test::data_file("kitti07-left-head");
  if (path.empty()) GTEST_SKIP() << porta::test::skip_reason("kitti07-left-head");
  const std::string message = error_of([&] { open_dataset(DatasetKind::kitti, path.string()); });
  EXPECT_NE(message.find("has no image_1 folder (right camera)"), std::string::npos) << message;
  EXPECT_NE(message.find(path.string()), std::string::npos) << message;
  EXPECT_NE(message.find("left-only"), std::string::npos) << message;
}

// ---- A synthetic stereo sequence in KITTI's layout -----------------------------------------------

TEST(DatasetKitti, SyntheticSequenceLoadsWithTheExactCameraTimesPosesAndPixels) {
  TempDir dir;
  const KittiSpec spec = write_kitti(dir.path());
  const auto dataset = open_dataset(DatasetKind::kitti, dir.path().string());
  ASSERT_EQ(dataset->size(), static_cast<std::size_t>(spec.frames));
  EXPECT_TRUE(dataset->has_right());
  const StereoCamera& camera = dataset->camera();
  EXPECT_EQ(camera.width, spec.width);
  EXPECT_EQ(camera.height, spec.height);
  EXPECT_EQ(camera.fx, spec.fx);
  EXPECT_EQ(camera.fy, spec.fy);
  EXPECT_EQ(camera.cx, spec.cx);
  EXPECT_EQ(camera.cy, spec.cy);
  EXPECT_NEAR(camera.baseline_m, spec.baseline, 1e-15);
  ASSERT_TRUE(dataset->ground_truth().has_value());
  const Trajectory& gt = *dataset->ground_truth();
  ASSERT_EQ(gt.size(), spec.poses.size());
  for (std::size_t i = 0; i < gt.size(); ++i) {
    EXPECT_DOUBLE_EQ(dataset->time_s(i), 0.1 * static_cast<double>(i) + 0.003);
    EXPECT_DOUBLE_EQ(gt.poses[i].time_s, dataset->time_s(i));
    EXPECT_LT((gt.poses[i].pose.matrix() - spec.poses[i].matrix()).cwiseAbs().maxCoeff(), 1e-12) << i;
  }
  for (std::size_t i = 0; i < dataset->size(); ++i) {
    const StereoPair pair = dataset->load(i);
    EXPECT_TRUE(same_pixels(pair.left, random_image(spec.width, spec.height, 2u * static_cast<unsigned>(i))));
    EXPECT_TRUE(
        same_pixels(pair.right, random_image(spec.width, spec.height, 2u * static_cast<unsigned>(i) + 1)));
  }
}

TEST(DatasetKitti, LoadFromSeveralThreadsGivesTheSamePairs) {
  TempDir dir;
  write_kitti(dir.path());
  const auto dataset = open_dataset(DatasetKind::kitti, dir.path().string());
  std::vector<StereoPair> sequential;
  for (std::size_t i = 0; i < dataset->size(); ++i) sequential.push_back(dataset->load(i));
  std::vector<std::thread> threads;
  std::vector<int> mismatches(4, 0);
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int round = 0; round < 5; ++round)
        for (std::size_t i = 0; i < dataset->size(); ++i) {
          const StereoPair pair = dataset->load(i);
          const auto same = [](const Image& a, const Image& b) {
            return a.size_bytes() == b.size_bytes() &&
                   std::equal(a.data(), a.data() + a.size_bytes(), b.data());
          };
          if (!same(pair.left, sequential[i].left) || !same(pair.right, sequential[i].right)) ++mismatches[t];
        }
    });
  for (auto& thread : threads) thread.join();
  for (int m : mismatches) EXPECT_EQ(m, 0);
}

TEST(DatasetKitti, GroundTruthPathOverridesAndLongerPoseFilesAreCutToTheFrames) {
  TempDir dir;
  const KittiSpec spec = write_kitti(dir.path());
  // A full-sequence pose file elsewhere (more poses than frames): the first `frames` are used.
  std::string poses;
  for (int i = 0; i < spec.frames + 3; ++i) poses += "1 0 0 " + std::to_string(i) + " 0 1 0 0 0 0 1 0\n";
  write_text(dir.path() / "elsewhere" / "07.txt", poses);
  DatasetOptions options;
  options.ground_truth_path = (dir.path() / "elsewhere" / "07.txt").string();
  const auto dataset = open_dataset(DatasetKind::kitti, dir.path().string(), options);
  ASSERT_TRUE(dataset->ground_truth().has_value());
  ASSERT_EQ(dataset->ground_truth()->size(), static_cast<std::size_t>(spec.frames));
  EXPECT_DOUBLE_EQ(dataset->ground_truth()->poses[3].pose.translation().x(), 3.0);
  EXPECT_DOUBLE_EQ(dataset->ground_truth()->poses[3].time_s, dataset->time_s(3));
}

// ---- Bad input -----------------------------------------------------------------------------------

TEST(DatasetKitti, MissingPathAndNotAFolderAreNamed) {
  TempDir dir;
  const fs::path missing = dir.path() / "nope";
  std::string message = error_of([&] { open_dataset(DatasetKind::kitti, missing.string()); });
  EXPECT_NE(message.find(missing.string()), std::string::npos) << message;
  EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
  write_text(dir.path() / "file.txt", "x");
  message = error_of([&] { open_dataset(DatasetKind::kitti, (dir.path() / "file.txt").string()); });
  EXPECT_NE(message.find("is not a folder"), std::string::npos) << message;
  message = error_of([&] { open_dataset(DatasetKind::kitti, ""); });
  EXPECT_NE(message.find("no path"), std::string::npos) << message;
}

TEST(DatasetKitti, MissingOrEmptyImageFoldersAreNamed) {
  TempDir dir;
  std::string message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("has no image_0 folder (left camera)"), std::string::npos) << message;
  fs::create_directories(dir.path() / "image_0");
  fs::create_directories(dir.path() / "image_1");
  message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("has no image files"), std::string::npos) << message;
  EXPECT_NE(message.find("image_0"), std::string::npos) << message;
}

TEST(DatasetKitti, LeftRightCountOrNameMismatchIsAnError) {
  TempDir dir;
  write_kitti(dir.path());
  fs::remove(dir.path() / "image_1" / "000004.png");
  std::string message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("5 images"), std::string::npos) << message;
  EXPECT_NE(message.find("4"), std::string::npos) << message;
  cv::imwrite((dir.path() / "image_1" / "000009.png").string(), random_image(64, 48, 1));
  message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("000004.png"), std::string::npos) << message;
  EXPECT_NE(message.find("000009.png"), std::string::npos) << message;
}

TEST(DatasetKitti, TimesCountMismatchIsAnError) {
  TempDir dir;
  write_kitti(dir.path());
  write_text(dir.path() / "times.txt", "0.0\n0.1\n0.2\n");
  const std::string message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("times.txt"), std::string::npos) << message;
  EXPECT_NE(message.find("has 3 times but"), std::string::npos) << message;
  EXPECT_NE(message.find("5 images"), std::string::npos) << message;
}

TEST(DatasetKitti, UnparsableTimesAndCalibrationLinesNameFileAndLine) {
  TempDir dir;
  write_kitti(dir.path());
  write_text(dir.path() / "times.txt", "0.0\n0.1\nzero.two\n0.3\n0.4\n");
  std::string message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("times.txt' line 3"), std::string::npos) << message;

  write_kitti(dir.path());
  write_text(dir.path() / "calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 -0.5 0 1 0 0 0 0 1 x\n");
  message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("calib.txt' line 2"), std::string::npos) << message;
  EXPECT_NE(message.find("'x'"), std::string::npos) << message;

  write_text(dir.path() / "calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 -0.5 0 1 0\n");
  message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("line 2: P1 has 7 numbers, expected 12"), std::string::npos) << message;

  write_text(dir.path() / "calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("has no P1 line"), std::string::npos) << message;

  fs::remove(dir.path() / "calib.txt");
  message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("has no calib.txt"), std::string::npos) << message;
}

TEST(DatasetKitti, TimesThatDoNotIncreaseAreRefusedWithTheLine) {
  // Accepted before, the run's output was then refused by `portaslam eval`.
  TempDir dir;
  write_kitti(dir.path());
  write_text(dir.path() / "times.txt", "0.0\n0.1\n0.1\n0.3\n0.4\n");
  std::string message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("times.txt' line 3: the time 0.1 s does not come after the one before (0.1 s)"),
            std::string::npos) << message;
  write_text(dir.path() / "times.txt", "0.0\n0.1\n0.2\n0.15\n0.4\n");
  message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("line 4: the time 0.15 s does not come after"), std::string::npos) << message;
  write_text(dir.path() / "times.txt", "0.0\n0.1\n0.2\n0.3\n1e300\n");
  message = error_of([&] { open_dataset(DatasetKind::kitti, dir.path().string()); });
  EXPECT_NE(message.find("line 5: the time 1e+300 s is outside"), std::string::npos) << message;
}

TEST(DatasetKitti, APngWithAHugeHeaderIsRefusedBeforeAnyAllocation) {
  // A valid PNG whose header claims 2^31-1 x 2^31-1 pixels: the size is checked before decoding,
  // and the message is ours (not "Failed to allocate ... bytes" from a library).
  TempDir dir;
  write_kitti(dir.path());
  const fs::path png = dir.path() / "image_0" / "000001.png";
  std::string bytes;
  {
    std::ifstream in(png, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(bytes.size(), 33u);
  for (int i = 16; i < 24; ++i) bytes[static_cast<std::size_t>(i)] = i % 4 == 0 ? '\x7f' : '\xff';
  std::ofstream(png, std::ios::binary | std::ios::trunc) << bytes;
  const auto dataset = open_dataset(DatasetKind::kitti, dir.path().string());
  const std::string message = error_of([&] { dataset->load(1); });
  EXPECT_NE(message.find("image_0/000001.png"), std::string::npos) << message;
  EXPECT_EQ(message.find("Failed to allocate"), std::string::npos) << message;
  EXPECT_TRUE(message.find("larger than the limit") != std::string::npos ||
              message.find("cannot decode image") != std::string::npos)
      << message;
}

TEST(DatasetKitti, CorruptOrWrongSizedImagesAreNamedWhenLoaded) {
  TempDir dir;
  write_kitti(dir.path());
  write_text(dir.path() / "image_1" / "000002.png", "this is not a PNG file");
  cv::imwrite((dir.path() / "image_0" / "000003.png").string(), random_image(60, 48, 9));
  const auto dataset = open_dataset(DatasetKind::kitti, dir.path().string());
  std::string message = error_of([&] { dataset->load(2); });
  EXPECT_NE(message.find("cannot decode image"), std::string::npos) << message;
  EXPECT_NE(message.find("image_1/000002.png"), std::string::npos) << message;
  message = error_of([&] { dataset->load(3); });
  EXPECT_NE(message.find("image_0/000003.png"), std::string::npos) << message;
  EXPECT_NE(message.find("is 60x48, expected 64x48"), std::string::npos) << message;
  message = error_of([&] { dataset->load(5); });
  EXPECT_NE(message.find("frame index 5 is out of range"), std::string::npos) << message;
  EXPECT_NE(message.find("has 5 frames"), std::string::npos) << message;
  fs::remove(dir.path() / "image_0" / "000001.png");
  fs::remove(dir.path() / "image_1" / "000004.png");
  message = error_of([&] { dataset->load(1); });
  EXPECT_NE(message.find("000001.png' is missing"), std::string::npos) << message;
}

}  // namespace
}  // namespace porta::slam

#endif  // PORTA_DATASET_BUILT
