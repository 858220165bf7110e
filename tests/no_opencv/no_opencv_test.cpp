// What a build without OpenCV (the GPU machine's) refuses, tested on a machine that has OpenCV:
// the dataset readers and the plots compiled as that build compiles them (tests/CMakeLists.txt,
// porta_no_opencv_tests). Rectified pairs and PNG images work; computing a rectification, reading
// another image format and drawing plots are refused with a message that says why.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "imageio/png_file.hpp"
#include "porta/slam/eval_report.hpp"
#include "porta/slam/evaluation.hpp"
#include "slam/dataset/dataset_internal.hpp"

namespace porta::slam::detail {
namespace {

namespace fs = std::filesystem;

template <typename Error, typename F>
std::string error_of(F&& run) {
  try {
    run();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an error";
  return {};
}

RawCamera camera(double k1 = 0.0) {
  RawCamera c;
  c.width = 64;
  c.height = 48;
  c.K << 60.0, 0.0, 32.0, 0.0, 60.0, 24.0, 0.0, 0.0, 1.0;
  if (k1 != 0.0) c.D = {k1, 0.0, 0.0, 0.0};
  return c;
}

TEST(NoOpenCV, ARectifiedPairPassesThroughAndARectificationIsRefused) {
  const Rectifier parallel = Rectifier::from_calibration(camera(), camera(), Eigen::Matrix3d::Identity(),
                                                         Eigen::Vector3d(-0.1, 0.0, 0.0));
  EXPECT_FALSE(parallel.remaps());
  EXPECT_EQ(parallel.camera().baseline_m, 0.1);
  std::string message = error_of<DatasetError>([] {
    Rectifier::from_calibration(camera(-0.2), camera(), Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.1, 0, 0));
  });
  EXPECT_NE(message.find("needs OpenCV (calib3d), and this build of PortaSLAM has none"), std::string::npos)
      << message;
  message = error_of<DatasetError>([&] { Rectifier::undistort_only(parallel.camera(), {-0.2, 0.0, 0.0, 0.0}); });
  EXPECT_NE(message.find("undistortion with the settings file's Camera.k1 k2 p1 p2 k3 needs OpenCV"),
            std::string::npos) << message;
}

TEST(NoOpenCV, PngImagesAreReadAndOtherFormatsAreRefused) {
  const fs::path dir = fs::temp_directory_path() / ("porta_no_opencv_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::vector<std::uint8_t> gray(64 * 48, 7);
  io::write_png_gray((dir / "a.png").string(), 64, 48, gray.data(), 64);
  const Image image = read_gray(dir / "a.png", 64, 48);
  EXPECT_EQ(image.at(10, 10), 7);
  std::ofstream(dir / "a.pgm") << "P5\n64 48\n255\n" << std::string(64 * 48, '\7');
  const std::string message = error_of<DatasetError>([&] { read_gray(dir / "a.pgm"); });
  EXPECT_NE(message.find("not a PNG file, and this build of PortaSLAM reads other formats only with OpenCV"),
            std::string::npos) << message;
  fs::remove_all(dir);
}

TEST(NoOpenCV, PlotsAreRefused) {
  EXPECT_FALSE(evaluation_plots_available());
  const std::string message =
      error_of<EvaluationError>([] { write_evaluation_plots("plots", EvaluationResult{}, "title"); });
  EXPECT_NE(message.find("plots are drawn with OpenCV, and this build of PortaSLAM has none"), std::string::npos)
      << message;
}

}  // namespace
}  // namespace porta::slam::detail
