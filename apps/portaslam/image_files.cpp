#include "image_files.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli_args.hpp"
#include "porta/settings.hpp"

namespace porta::app {

namespace {

std::string quoted(const std::string& path) { return "'" + path + "'"; }

// 16-bit and float images keep their full range through a linear map to [0, 255].
cv::Mat to_8bit(const cv::Mat& m, std::string& conversion) {
  if (m.depth() == CV_8U) return m;
  cv::Mat out;
  if (m.depth() == CV_16U) {
    m.convertTo(out, CV_8U, 1.0 / 257.0);
    conversion += "16-bit to 8-bit";
    return out;
  }
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(m.reshape(1), &lo, &hi);
  m.convertTo(out, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0, hi > lo ? -lo * 255.0 / (hi - lo) : 0.0);
  conversion += "scaled to 8-bit";
  return out;
}

}  // namespace

LoadedImage load_gray_image(const std::string& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) throw CliError("cannot open image " + quoted(path) + ": no such file");
  if (std::filesystem::is_directory(status))
    throw CliError("cannot open image " + quoted(path) + ": it is a directory, not an image file");
  if (!std::ifstream(path, std::ios::binary))
    throw CliError("cannot open image " + quoted(path) + ": " + std::strerror(errno));

  cv::Mat decoded;
  try {
    decoded = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw CliError("cannot decode image " + quoted(path) + ": " + e.what());
  }
  if (decoded.empty())
    throw CliError("cannot decode image " + quoted(path) +
                   ": not an image file OpenCV can read (corrupt, truncated, or not an image)");
  if (decoded.cols > kMaxImageSide || decoded.rows > kMaxImageSide)
    throw CliError("image " + quoted(path) + " is " + std::to_string(decoded.cols) + "x" +
                   std::to_string(decoded.rows) + ": larger than the engine's limit of " +
                   std::to_string(kMaxImageSide) + " px per side");

  LoadedImage loaded;
  cv::Mat gray = to_8bit(decoded, loaded.conversion);
  if (gray.channels() != 1) {
    const int channels = gray.channels();
    cv::Mat single;
    if (channels == 3 || channels == 4)
      cv::cvtColor(gray, single, channels == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    else
      cv::extractChannel(gray, single, 0);  // gray + alpha: keep the gray
    gray = single;
    loaded.conversion += std::string(loaded.conversion.empty() ? "" : ", ") + std::to_string(channels) +
                         "-channel color to gray";
  }
  loaded.gray = Image(gray.cols, gray.rows);
  for (int y = 0; y < gray.rows; ++y)
    std::memcpy(loaded.gray.row(y), gray.ptr<std::uint8_t>(y), static_cast<std::size_t>(gray.cols));
  return loaded;
}

}  // namespace porta::app
