// imageio/'s PNG reader and writer (used by portaslam and the tests where OpenCV is absent) against
// OpenCV on the same files: the gray bytes must equal what OpenCV's imread(IMREAD_UNCHANGED),
// convertTo(CV_8U, 1/257) and cvtColor(..2GRAY) give, the path portaslam takes with OpenCV.
#if PORTA_TESTS_HAVE_PNG_IO

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <unistd.h>
#include <vector>

#include "imageio/png_file.hpp"

namespace porta {
namespace {

namespace fs = std::filesystem;

class PngFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("porta_png_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // A random image of `type` written by OpenCV.
  std::string write_random(const std::string& name, int type, int width = 67, int height = 41) {
    cv::Mat m(height, width, type);
    cv::randu(m, cv::Scalar::all(0), cv::Scalar::all(CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256));
    EXPECT_TRUE(cv::imwrite(path(name), m));
    return path(name);
  }

  fs::path dir_;
};

// What portaslam's OpenCV build makes of a file (apps/portaslam/image_files.cpp).
cv::Mat opencv_gray(const std::string& file) {
  cv::Mat m = cv::imread(file, cv::IMREAD_UNCHANGED);
  if (m.depth() == CV_16U) m.convertTo(m, CV_8U, 1.0 / 257.0);
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
  if (m.channels() == 4) cv::cvtColor(m, m, cv::COLOR_BGRA2GRAY);
  return m;
}

// Reads `file` with imageio and requires OpenCV's bytes and the given conversion text.
void expect_read_as_opencv_does(const std::string& file, const std::string& conversion) {
  SCOPED_TRACE(file);
  const io::GrayPng png = io::read_png_gray(file, 16384);
  const cv::Mat theirs = opencv_gray(file);
  ASSERT_EQ(png.gray.width(), theirs.cols);
  ASSERT_EQ(png.gray.height(), theirs.rows);
  long differing = 0;
  for (int y = 0; y < theirs.rows; ++y)
    for (int x = 0; x < theirs.cols; ++x) differing += png.gray.at(x, y) != theirs.at<std::uint8_t>(y, x);
  EXPECT_EQ(differing, 0) << "pixels that differ from OpenCV's";
  EXPECT_EQ(png.conversion, conversion);
}

TEST_F(PngFileTest, EightBitGrayIsReadAsIs) {
  expect_read_as_opencv_does(write_random("gray8.png", CV_8UC1), "");
}

TEST_F(PngFileTest, ColourBecomesGrayWithOpenCvWeights) {
  expect_read_as_opencv_does(write_random("rgb.png", CV_8UC3), "3-channel color to gray");
  expect_read_as_opencv_does(write_random("rgba.png", CV_8UC4), "4-channel color to gray (alpha dropped)");
}

TEST_F(PngFileTest, SixteenBitIsScaledTo8Bit) {
  expect_read_as_opencv_does(write_random("gray16.png", CV_16UC1), "16-bit to 8-bit");
  expect_read_as_opencv_does(write_random("rgb16.png", CV_16UC3), "16-bit to 8-bit, 3-channel color to gray");
}

TEST_F(PngFileTest, WrittenRgbReadsBackInOpenCv) {
  const int width = 31, height = 17;
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(width) * height * 3);
  std::mt19937 random(7);
  for (auto& v : rgb) v = static_cast<std::uint8_t>(random());
  io::write_png_rgb(path("out.png"), width, height, rgb.data(), static_cast<std::size_t>(width) * 3);
  const cv::Mat back = cv::imread(path("out.png"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.type(), CV_8UC3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(back.at<cv::Vec3b>(y, x)[2 - c], rgb[(static_cast<std::size_t>(y) * width + x) * 3 + c]);
  EXPECT_THROW(io::write_png_rgb(path("no/such/folder/out.png"), width, height, rgb.data(), width * 3),
               io::PngError);
}

io::PngError::Kind kind_of_failure(const std::string& file, int max_side = 16384) {
  try {
    io::read_png_gray(file, max_side);
  } catch (const io::PngError& e) {
    return e.kind();
  }
  ADD_FAILURE() << file << " was read without error";
  return io::PngError::Kind::unwritable;
}

TEST_F(PngFileTest, BadFilesAreNamedForWhatTheyAre) {
  using Kind = io::PngError::Kind;
  EXPECT_EQ(kind_of_failure(path("missing.png")), Kind::unreadable);
  std::ofstream(path("empty.png")).close();
  EXPECT_EQ(kind_of_failure(path("empty.png")), Kind::not_png);
  std::ofstream(path("text.png")) << "This is a text file, not a PNG.\n";
  EXPECT_EQ(kind_of_failure(path("text.png")), Kind::not_png);

  // A real PNG cut in half: the signature is there, the pixel data is not.
  const std::string whole = write_random("whole.png", CV_8UC1, 200, 100);
  std::ifstream in(whole, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(path("truncated.png"), std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_EQ(kind_of_failure(path("truncated.png")), Kind::corrupt);
  try {
    io::read_png_gray(path("truncated.png"), 16384);
  } catch (const io::PngError& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt or truncated PNG (libpng: "), std::string::npos) << e.what();
  }

  // Too large: rejected from the header, with the size.
  try {
    io::read_png_gray(whole, 150);
    ADD_FAILURE() << "a 200x100 image passed a limit of 150 px";
  } catch (const io::PngError& e) {
    EXPECT_EQ(e.kind(), Kind::too_large);
    EXPECT_EQ(e.width(), 200);
    EXPECT_EQ(e.height(), 100);
  }
}

}  // namespace
}  // namespace porta

#endif  // PORTA_TESTS_HAVE_PNG_IO
