// ORB-SLAM2-style YAML settings files: the shipped settings/*.yaml, the camera and frontend settings
// they give, and the errors for missing files, non-YAML, wrong key types and bad values.
#if PORTA_DATASET_BUILT

#include "porta/slam/settings_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/LU>
#include <filesystem>
#include <fstream>
#include <string>

namespace porta::slam {
namespace {

namespace fs = std::filesystem;

const fs::path kSettingsDir = fs::path(__FILE__).parent_path().parent_path().parent_path() / "settings";

class TempFile {
 public:
  explicit TempFile(const std::string& content) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() / ("porta_settings_" + std::to_string(::getpid()) + "_" + info->name() +
                                         "_" + std::to_string(counter_++) + ".yaml");
    std::ofstream(path_) << content;
  }
  ~TempFile() {
    std::error_code ec;
    fs::remove(path_, ec);
  }
  std::string path() const { return path_.string(); }

 private:
  static inline int counter_ = 0;
  fs::path path_;
};

template <typename F>
std::string error_of(F&& run) {
  try {
    run();
  } catch (const SettingsFileError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected SettingsFileError, got another exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected SettingsFileError, nothing was thrown";
  return {};
}

const char* const kMinimal =
    "%YAML:1.0\nCamera.fx: 500.0\nCamera.fy: 500.0\nCamera.cx: 320.0\nCamera.cy: 240.0\nCamera.bf: 60.0\n"
    "Camera.width: 640\nCamera.height: 480\n";

// ---- The shipped settings files ------------------------------------------------------------------

TEST(SettingsFile, KittiSettingsGiveKitti00Camera) {
  const SettingsFile s = read_settings_file((kSettingsDir / "KITTI00-02.yaml").string());
  const StereoCamera camera = s.stereo_camera();
  EXPECT_EQ(camera.width, 1241);
  EXPECT_EQ(camera.height, 376);
  EXPECT_EQ(camera.fx, 718.856);
  EXPECT_EQ(camera.fy, 718.856);
  EXPECT_EQ(camera.cx, 607.1928);
  EXPECT_EQ(camera.cy, 185.2157);
  EXPECT_DOUBLE_EQ(camera.bf(), 386.1448);
  EXPECT_NEAR(camera.baseline_m, 0.5372, 1e-4);
  EXPECT_FALSE(s.has_rectification());
  EXPECT_FALSE(s.has_distortion());
  EXPECT_EQ(s.fps, 10.0);
  EXPECT_EQ(s.rgb, true);
  EXPECT_EQ(s.th_depth, 35.0);
  EXPECT_EQ(s.orb_features, 2000);
  EXPECT_EQ(s.orb_min_th_fast, 7);

  FrontendSettings frontend;
  frontend.levels = 4;
  frontend.scale_factor = 1.5;
  frontend.fast_threshold = 9;
  s.apply_to(frontend);
  EXPECT_EQ(frontend.levels, 8);
  EXPECT_EQ(frontend.scale_factor, 1.2);
  EXPECT_EQ(frontend.fast_threshold, 20);
}

TEST(SettingsFile, EurocSettingsCarryTheStereoRectification) {
  const SettingsFile s = read_settings_file((kSettingsDir / "EuRoC.yaml").string());
  ASSERT_TRUE(s.has_rectification());
  EXPECT_NO_THROW(s.check_rectification_complete());
  EXPECT_EQ(*s.left.width, 752);
  EXPECT_EQ(*s.right.height, 480);
  EXPECT_EQ((*s.left.K)(0, 0), 458.654);
  EXPECT_EQ((*s.right.K)(1, 2), 255.238);
  ASSERT_EQ(s.left.D->size(), 5u);
  EXPECT_EQ((*s.left.D)[0], -0.28340811);
  EXPECT_NEAR(s.left.R->determinant(), 1.0, 1e-9);
  EXPECT_NEAR(((*s.right.R) * s.right.R->transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-9);
  EXPECT_EQ((*s.right.P)(0, 3), -48.019761960624088);
  const StereoCamera camera = s.stereo_camera();
  EXPECT_EQ(camera.fx, (*s.left.P)(0, 0));
  EXPECT_EQ(camera.cx, (*s.left.P)(0, 2));
  EXPECT_EQ(camera.cy, (*s.left.P)(1, 2));
  EXPECT_NEAR(camera.baseline_m, -(*s.right.P)(0, 3) / (*s.right.P)(0, 0), 1e-15);
  EXPECT_NEAR(camera.baseline_m, 0.1101, 2e-4);
  EXPECT_EQ(s.orb_features, 1200);
}

// ---- Reading -------------------------------------------------------------------------------------

TEST(SettingsFile, AbsentKeysStayEmptyAndIntegralRealsAreIntegers) {
  const TempFile file("Camera.fx: 500\nCamera.width: 640.0\nORBextractor.nLevels: 4\n");  // no %YAML line
  const SettingsFile s = read_settings_file(file.path());
  EXPECT_EQ(s.fx, 500.0);   // an integer is a fine number
  EXPECT_EQ(s.width, 640);  // ORB-SLAM2 files write sizes as reals
  EXPECT_FALSE(s.fy.has_value());
  EXPECT_FALSE(s.left.any());
  FrontendSettings frontend;
  s.apply_to(frontend);
  EXPECT_EQ(frontend.levels, 4);
  EXPECT_EQ(frontend.scale_factor, 1.2);  // untouched
}

TEST(SettingsFile, MissingFileAndNonYamlNameTheFile) {
  std::string message = error_of([] { read_settings_file("/nonexistent/porta/settings.yaml"); });
  EXPECT_NE(message.find("'/nonexistent/porta/settings.yaml': no such file"), std::string::npos) << message;
  const TempFile prose("This is a README, not a settings file.\n");
  message = error_of([&] { read_settings_file(prose.path()); });
  EXPECT_NE(message.find(prose.path()), std::string::npos) << message;
  EXPECT_NE(message.find("not valid YAML"), std::string::npos) << message;
  const TempFile broken("%YAML:1.0\nCamera.fx: 500.0\nLEFT.D: [1, 2\n");
  message = error_of([&] { read_settings_file(broken.path()); });
  EXPECT_NE(message.find("not valid YAML: line 3"), std::string::npos) << message;
  const TempFile empty("");
  message = error_of([&] { read_settings_file(empty.path()); });
  EXPECT_NE(message.find("empty"), std::string::npos) << message;
  message = error_of([&] { read_settings_file(fs::temp_directory_path().string()); });
  EXPECT_NE(message.find("folder"), std::string::npos) << message;
}

TEST(SettingsFile, WrongTypesNameFileAndKey) {
  const auto message_for = [](const std::string& content) {
    const TempFile file(content);
    std::string message = error_of([&] { read_settings_file(file.path()); });
    EXPECT_NE(message.find(file.path()), std::string::npos) << message;
    return message;
  };
  std::string message = message_for("%YAML:1.0\nCamera.fx: fast\n");
  EXPECT_NE(message.find("key 'Camera.fx' must be a number, found the text 'fast'"), std::string::npos)
      << message;
  message = message_for("%YAML:1.0\nCamera.width: 752.5\n");
  EXPECT_NE(message.find("key 'Camera.width' must be an integer, found 752.5"), std::string::npos) << message;
  message = message_for("%YAML:1.0\nCamera.RGB: 2\n");
  EXPECT_NE(message.find("key 'Camera.RGB' must be 0 or 1"), std::string::npos) << message;
  message = message_for("%YAML:1.0\nORBextractor.nLevels: [8]\n");
  EXPECT_NE(message.find("key 'ORBextractor.nLevels' must be an integer, found a list"), std::string::npos)
      << message;
  message = message_for(
      "%YAML:1.0\nLEFT.K: !!opencv-matrix\n   rows: 2\n   cols: 2\n   dt: d\n   data: [1.0, 0.0, 0.0, "
      "1.0]\n");
  EXPECT_NE(message.find("key 'LEFT.K' must be a 3x3 matrix, found 2x2"), std::string::npos) << message;
  message = message_for("%YAML:1.0\nRIGHT.D: [0.1, 0.2]\n");
  EXPECT_NE(message.find("key 'RIGHT.D' must be a 1x4 or 1x5 matrix"), std::string::npos) << message;
  message = message_for("%YAML:1.0\nRIGHT.P: 3.0\n");
  EXPECT_NE(message.find("key 'RIGHT.P' must be an !!opencv-matrix, found a number"), std::string::npos)
      << message;
  message = message_for("%YAML:1.0\nCamera.fps: 0\n");
  EXPECT_NE(message.find("key 'Camera.fps' must be > 0"), std::string::npos) << message;
}

TEST(SettingsFile, StereoCameraNamesTheMissingKey) {
  std::string content = kMinimal;
  EXPECT_NO_THROW(read_settings_file(TempFile(content).path()).stereo_camera());
  for (const std::string key : {"Camera.fx", "Camera.cy", "Camera.bf", "Camera.width", "Camera.height"}) {
    std::string without = content;
    const auto at = without.find(key + ":");
    without.erase(at, without.find('\n', at) - at + 1);
    const TempFile file(without);
    const SettingsFile s = read_settings_file(file.path());
    const std::string message = error_of([&] { s.stereo_camera(); });
    EXPECT_NE(message.find("key '" + key + "' is missing"), std::string::npos) << message;
    EXPECT_NE(message.find(file.path()), std::string::npos) << message;
  }
  std::string bad = content;
  bad.replace(bad.find("Camera.bf: 60.0"), 15, "Camera.bf: -6.0");
  const TempFile bad_file(bad);
  const std::string message = error_of([&] { read_settings_file(bad_file.path()).stereo_camera(); });
  EXPECT_NE(message.find("baseline"), std::string::npos) << message;
}

TEST(SettingsFile, ApplyToRejectsBadValuesNamingTheKeyAndLeavesSettingsUnchanged) {
  const TempFile levels(std::string(kMinimal) + "ORBextractor.nLevels: 20\nORBextractor.iniThFAST: 12\n");
  FrontendSettings frontend;
  frontend.fast_threshold = 31;
  std::string message = error_of([&] { read_settings_file(levels.path()).apply_to(frontend); });
  EXPECT_NE(message.find("key 'ORBextractor.nLevels' = 20"), std::string::npos) << message;
  EXPECT_NE(message.find(levels.path()), std::string::npos) << message;
  EXPECT_EQ(frontend.levels, 8);
  EXPECT_EQ(frontend.fast_threshold, 31);
  const TempFile scale("ORBextractor.scaleFactor: 2.5\n");
  message = error_of([&] { read_settings_file(scale.path()).apply_to(frontend); });
  EXPECT_NE(message.find("key 'ORBextractor.scaleFactor' = 2.5"), std::string::npos) << message;
  const TempFile fast("ORBextractor.iniThFAST: 0\n");
  message = error_of([&] { read_settings_file(fast.path()).apply_to(frontend); });
  EXPECT_NE(message.find("key 'ORBextractor.iniThFAST' = 0"), std::string::npos) << message;
}

TEST(SettingsFile, PartialRectificationBlockNamesTheMissingKey) {
  std::ifstream in(kSettingsDir / "EuRoC.yaml");
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  content.replace(content.find("RIGHT.R:"), 8, "RIGHT.Rot:");
  const TempFile file(content);
  const SettingsFile s = read_settings_file(file.path());
  EXPECT_FALSE(s.has_rectification());
  const std::string message = error_of([&] { s.check_rectification_complete(); });
  EXPECT_NE(message.find("key 'RIGHT.R' is missing"), std::string::npos) << message;
}

// ---- Values beyond what a number or a camera can be ---------------------------------------------

TEST(SettingsFile, IntegersBeyond32BitsAreRefusedAsWrittenNotWrapped) {
  // OpenCV wraps 4294968538 to 1242, which then passed every range check.
  const TempFile wide(std::string(kMinimal) + "ORBextractor.nLevels: 4294967304\n");
  std::string message = error_of([&] { read_settings_file(wide.path()); });
  EXPECT_NE(message.find("line 9: the integer 4294967304 is out of range (beyond 32 bits)"), std::string::npos)
      << message;
  const TempFile negative(std::string(kMinimal) + "ORBextractor.iniThFAST: -2147483649\n");
  message = error_of([&] { read_settings_file(negative.path()); });
  EXPECT_NE(message.find("the integer -2147483649 is out of range"), std::string::npos) << message;
  // The 32-bit extremes themselves, keys with digits and real numbers are not integers to refuse.
  const TempFile edge(std::string(kMinimal) + "ORBextractor.iniThFAST: 2147483647\nCamera.k1: 12345678901.5e-12\n");
  EXPECT_NO_THROW(read_settings_file(edge.path()));
}

TEST(SettingsFile, DistortionCoefficientsBeyondAnyLensAreRefused) {
  const TempFile k1(std::string(kMinimal) + "Camera.k1: 1e10\n");
  std::string message = error_of([&] { read_settings_file(k1.path()); });
  EXPECT_NE(message.find("key 'Camera.k1' is 1e+10: a distortion coefficient must lie in [-100, 100]"),
            std::string::npos) << message;
  const TempFile camera(std::string(kMinimal).replace(std::string(kMinimal).find("500.0"), 5, "1e300"));
  message = error_of([&] { read_settings_file(camera.path()).stereo_camera(); });
  EXPECT_NE(message.find("fx 1e+300 is outside"), std::string::npos) << message;
}

TEST(SettingsFile, AMatrixHeaderIsCheckedBeforeAnythingIsAllocated) {
  // Found by fuzzing: OpenCV's own matrix reader allocated rows x cols from the header first.
  const TempFile huge("%YAML:1.0\nLEFT.K: !!opencv-matrix\n   rows: 3\n   cols: 2000000000\n   dt: d\n"
                      "   data: [1.0, 0.0, 0.0]\n");
  std::string message = error_of([&] { read_settings_file(huge.path()); });
  EXPECT_NE(message.find("key 'LEFT.K' is not a readable !!opencv-matrix: 'cols' is 2000000000, outside [1, 16]"),
            std::string::npos) << message;
  const TempFile short_data("%YAML:1.0\nLEFT.K: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                            "   data: [1.0, 0.0, 0.0]\n");
  message = error_of([&] { read_settings_file(short_data.path()); });
  EXPECT_NE(message.find("3x3 needs 9 numbers, 'data' has 3"), std::string::npos) << message;
}

TEST(SettingsFile, ALineIndentedLessThanTheFirstKeyIsRefusedWithItsLine) {
  // Found by fuzzing: OpenCV 4.6's YAML parser never returned on such files (our reader,
  // yaml_reader.cpp, replaced it; tests/slam/yaml_reader_test.cpp has the reproducers).
  const TempFile dedent(" t: d\n3: -\n\n");
  const std::string message = error_of([&] { read_settings_file(dedent.path()); });
  EXPECT_NE(message.find("not valid YAML: line 2: is indented less than the first key (line 1)"), std::string::npos)
      << message;
  // Indented keys that stay indented, comments and directives are still fine.
  const TempFile indented("%YAML:1.0\n# comment\n  Camera.fx: 500.0\n  Camera.fy: 500.0\n");
  EXPECT_NO_THROW(read_settings_file(indented.path()));
}

TEST(SettingsFile, AnEmptyListIsRefusedWithTheKey) {
  // Found by fuzzing: an empty "D: []" made OpenCV throw from inside our reader.
  const TempFile empty("%YAML:1.0\nLEFT.D: []\n");
  const std::string message = error_of([&] { read_settings_file(empty.path()); });
  EXPECT_NE(message.find("key 'LEFT.D' is an empty list; expected numbers"), std::string::npos) << message;
}

TEST(SettingsFile, AMalformedTreeIsNamedWithItsLine) {
  // Found by fuzzing: cv::FileStorage::operator[] threw "isMap()" on this file.
  const TempFile odd(std::string(" o%Y, CALIfpsdt: d\n \n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n--------,\n Camera.fps# 0000no   ls: ------/--- 0.0------,-"));
  const std::string message = error_of([&] { read_settings_file(odd.path()); });
  EXPECT_NE(message.find("': not valid YAML: line 33: is indented less than the first key (line 1)"), std::string::npos) << message;
}

}  // namespace
}  // namespace porta::slam

#endif  // PORTA_DATASET_BUILT
