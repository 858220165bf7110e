// Trajectory files (TUM, KITTI, EuRoC): exact round trips, format detection, the real shared
// ground-truth files, and an error naming file and line for every kind of bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "porta/slam/stereo_camera.hpp"
#include "porta/slam/trajectory_io.hpp"
#include "support/data_path.hpp"

namespace porta::slam {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("porta_traj_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string file(const std::string& name, const std::string& contents = "") const {
    const std::string p = (path_ / name).string();
    if (!contents.empty()) std::ofstream(p) << contents;
    return p;
  }

 private:
  fs::path path_;
};

Trajectory spiral(int n) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    StampedPose p;
    p.time_s = 1403715524.5 + 0.05 * i;
    p.pose.linear() = Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
    p.pose.translation() = Eigen::Vector3d(std::cos(0.1 * i), 0.01 * i, std::sin(0.1 * i)) * 3.0;
    t.poses.push_back(p);
  }
  return t;
}

void expect_same_poses(const Trajectory& a, const Trajectory& b, double tolerance) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR((a.poses[i].pose.matrix() - b.poses[i].pose.matrix()).cwiseAbs().maxCoeff(), 0.0, tolerance)
        << "pose " << i;
  }
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const TrajectoryError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(TrajectoryIo, TumAndKittiRoundTripExactly) {
  TempDir dir;
  const Trajectory original = spiral(40);
  for (TrajectoryFormat format : {TrajectoryFormat::tum, TrajectoryFormat::kitti}) {
    const std::string path = dir.file(std::string("traj.") + to_string(format));
    write_trajectory(path, original, format);
    EXPECT_EQ(detect_trajectory_format(path), format);
    const Trajectory back = read_trajectory(path);
    expect_same_poses(original, back, 1e-12);
    if (format == TrajectoryFormat::tum) {
      for (std::size_t i = 0; i < back.size(); ++i) EXPECT_EQ(back.poses[i].time_s, original.poses[i].time_s);
    } else {
      EXPECT_FALSE(back.has_times);
      EXPECT_EQ(back.poses[7].time_s, 7.0);  // the line index stands in for the time
    }
  }
}

TEST(TrajectoryIo, KittiWithTimesFileHasTimes) {
  TempDir dir;
  const Trajectory original = spiral(12);
  const std::string poses = dir.file("poses.txt");
  const std::string times = dir.file("times.txt");
  write_trajectory(poses, original, TrajectoryFormat::kitti);
  write_kitti_times(times, original);
  const Trajectory back = read_trajectory(poses, TrajectoryFormat::kitti, times);
  EXPECT_TRUE(back.has_times);
  for (std::size_t i = 0; i < back.size(); ++i) EXPECT_EQ(back.poses[i].time_s, original.poses[i].time_s);
}

TEST(TrajectoryIo, EurocRoundTripKeepsNanosecondTimesToDoublePrecision) {
  TempDir dir;
  const Trajectory original = spiral(20);
  const std::string path = dir.file("gt.csv");
  write_trajectory(path, original, TrajectoryFormat::euroc);
  EXPECT_EQ(detect_trajectory_format(path), TrajectoryFormat::euroc);
  const Trajectory back = read_trajectory(path);
  expect_same_poses(original, back, 1e-12);
  for (std::size_t i = 0; i < back.size(); ++i) EXPECT_NEAR(back.poses[i].time_s, original.poses[i].time_s, 1e-6);
}

TEST(TrajectoryIo, ReadsTheRealSharedTrajectories) {
  const fs::path kitti00 = porta::test::data_file("gt-trajectories/kitti00_poses.txt");
  if (kitti00.empty()) GTEST_SKIP() << porta::test::skip_reason("gt-trajectories/kitti00_poses.txt");
  const Trajectory k00 = read_trajectory(kitti00.string(), TrajectoryFormat::kitti,
                                         porta::test::data_file("gt-trajectories/kitti00_times.txt").string());
  EXPECT_EQ(k00.size(), 4541u);
  EXPECT_TRUE(k00.has_times);
  EXPECT_NEAR(k00.poses[1].time_s, 0.1037359, 1e-9);
  EXPECT_NEAR(k00.poses[1].pose.translation().z(), 0.8586941, 1e-9);
  EXPECT_NEAR(k00.path_length_m(), 3724.0, 30.0);  // KITTI 00 is a 3.7 km drive

  const Trajectory k07 = read_trajectory(porta::test::data_file("gt-trajectories/kitti07_times_poses.txt").string());
  EXPECT_EQ(k07.size(), 1101u);
  EXPECT_TRUE(k07.has_times);
  EXPECT_NEAR(k07.poses[1].time_s, 0.1038752, 1e-9);

  const Trajectory v102 = read_trajectory(porta::test::data_file("gt-trajectories/euroc_v102_groundtruth.csv").string());
  EXPECT_EQ(v102.size(), 16702u);
  EXPECT_NEAR(v102.poses[0].time_s, 1403715524.907143168, 1e-6);
  EXPECT_NEAR(v102.poses[0].pose.translation().x(), 0.515356, 1e-12);
  // The ASL quaternion order is w, x, y, z.
  const Eigen::Quaterniond q(v102.poses[0].pose.rotation());
  EXPECT_NEAR(std::abs(q.w()), 0.161996, 1e-5);
}

TEST(TrajectoryIo, BadInputNamesFileAndLine) {
  TempDir dir;
  EXPECT_NE(error_of([&] { read_trajectory(dir.file("missing.txt")); }).find("cannot be opened"), std::string::npos);
  const std::string empty = dir.file("empty.txt", "# only a comment\n\n");
  EXPECT_NE(error_of([&] { read_trajectory(empty); }).find("has no poses"), std::string::npos);
  const std::string bad_number = dir.file("bad.txt", "0 0 0 0 0 0 0 1\n0.1 0 zero 0 0 0 0 1\n");
  const std::string message = error_of([&] { read_trajectory(bad_number); });
  EXPECT_NE(message.find("line 2"), std::string::npos) << message;
  EXPECT_NE(message.find("'zero'"), std::string::npos) << message;
  const std::string zero_quaternion = dir.file("q0.txt", "0 0 0 0 0 0 0 0\n");
  EXPECT_NE(error_of([&] { read_trajectory(zero_quaternion); }).find("zero length"), std::string::npos);
  const std::string not_rotation = dir.file("notrot.txt", "2 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_NE(error_of([&] { read_trajectory(not_rotation); }).find("not a rotation"), std::string::npos);
  const std::string backwards = dir.file("back.txt", "1 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n");
  EXPECT_NE(error_of([&] { read_trajectory(backwards); }).find("times must increase"), std::string::npos);
  const std::string nine = dir.file("nine.txt", "1 2 3 4 5 6 7 8 9\n");
  EXPECT_NE(error_of([&] { read_trajectory(nine); }).find("cannot tell the format"), std::string::npos);
  const std::string poses = dir.file("p.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n");
  const std::string times = dir.file("t.txt", "0\n");
  EXPECT_NE(error_of([&] { read_trajectory(poses, TrajectoryFormat::kitti, times); }).find("has 1 times"),
            std::string::npos);
  const std::string short_csv = dir.file("short.csv", "1403715524907143168,1,2,3\n");
  EXPECT_NE(error_of([&] { read_trajectory(short_csv); }).find("at least 8"), std::string::npos);
  EXPECT_NE(error_of([&] { write_trajectory(dir.file("no/such/dir/x.txt"), spiral(2), TrajectoryFormat::tum); })
                .find("cannot write"),
            std::string::npos);
}

TEST(TrajectoryIo, ValuesBeyondTheBoundsAreRefusedNotEvaluatedToInf) {
  TempDir dir;
  // 1e300 squared is inf: such a file used to give "ATE RMSE inf m" and exit 0.
  const std::string huge = dir.file("huge.txt", "1 0 0 1e300 0 1 0 0 0 0 1 0\n1 0 0 -1e300 0 1 0 0 0 0 1 1\n");
  std::string message = error_of([&] { read_trajectory(huge); });
  EXPECT_NE(message.find("pose 0 has a coordinate beyond 1e+09 m (1e+300)"), std::string::npos) << message;
  const std::string late = dir.file("late.txt", "1e300 0 0 0 0 0 0 1\n");
  message = error_of([&] { read_trajectory(late); });
  EXPECT_NE(message.find("has the time 1e+300 s"), std::string::npos) << message;
  // At the bounds a file is still read.
  const std::string far = dir.file("far.txt", "1 0 0 1e9 0 1 0 -1e9 0 0 1 0\n");
  EXPECT_EQ(read_trajectory(far).size(), 1u);
}

TEST(StereoCamera, ValuesNoRealCameraHasAreRefusedWithValueAndRange) {
  const StereoCamera kitti{1242, 375, 718.856, 718.856, 607.19, 185.22, 0.537};
  EXPECT_NO_THROW(kitti.validate());
  const auto message = [](StereoCamera c) {
    try {
      c.validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  StereoCamera c = kitti;
  c.fx = 1e300;  // used to overflow the renderer's pixel arithmetic (SIGSEGV)
  EXPECT_NE(message(c).find("fx 1e+300 is outside [248.4, 124200] px for a 1242x375 image"), std::string::npos)
      << message(c);
  c = kitti;
  c.fy = 10.0;
  EXPECT_NE(message(c).find("fy 10 is outside"), std::string::npos) << message(c);
  c = kitti;
  c.cx = 1300.0;
  EXPECT_NE(message(c).find("cx 1300 is outside the image, [0, 1242]"), std::string::npos) << message(c);
  c = kitti;
  c.cy = -1.0;
  EXPECT_NE(message(c).find("cy -1 is outside the image"), std::string::npos) << message(c);
  c = kitti;
  c.baseline_m = 1e-300 / c.fx;  // bf 1e-300
  EXPECT_NE(message(c).find("m is outside [0.001, 100] m"), std::string::npos) << message(c);
  c = kitti;
  c.baseline_m = 1e6;
  EXPECT_NE(message(c).find("baseline 1e+06 m"), std::string::npos) << message(c);
}

TEST(Pose, RotationAngleIsAccurateNearZeroAndPi) {
  for (double angle : {0.0, 1e-9, 1e-4, 0.5, 3.0, M_PI - 1e-6, M_PI}) {
    const Eigen::Matrix3d r = Eigen::AngleAxisd(angle, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    EXPECT_NEAR(rotation_angle_rad(r), angle, 1e-9) << angle;
  }
}

TEST(StereoCamera, ValidateNamesTheBadField) {
  StereoCamera camera{752, 480, 458.0, 457.0, 367.0, 248.0, 0.11};
  EXPECT_NO_THROW(camera.validate());
  EXPECT_DOUBLE_EQ(camera.bf(), 458.0 * 0.11);
  camera.baseline_m = 0.0;
  try {
    camera.validate();
    FAIL() << "a zero baseline was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("baseline"), std::string::npos) << e.what();
  }
  camera.baseline_m = 0.11;
  camera.width = 0;
  EXPECT_THROW(camera.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace porta::slam
