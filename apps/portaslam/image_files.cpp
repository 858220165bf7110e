#include "image_files.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>

#if PORTA_APPS_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#endif
#include "imageio/png_file.hpp"

#include "cli_args.hpp"
#include "porta/settings.hpp"

namespace porta::app {

namespace {

std::string quoted(const std::string& path) { return "'" + path + "'"; }

std::string too_large_message(const std::string& path, int width, int height) {
  return "image " + quoted(path) + " is " + std::to_string(width) + "x" + std::to_string(height) +
         ": larger than the engine's limit of " + std::to_string(kMaxImageSide) + " px per side";
}

// Missing files, folders and unreadable files get the same messages in every build.
void check_readable(const std::string& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) throw CliError("cannot open image " + quoted(path) + ": no such file");
  if (std::filesystem::is_directory(status))
    throw CliError("cannot open image " + quoted(path) + ": it is a directory, not an image file");
  if (!std::ifstream(path, std::ios::binary))
    throw CliError("cannot open image " + quoted(path) + ": " + std::strerror(errno));
}

// PNG files are read through libpng in every build (the same bytes as OpenCV would give, see
// png_file.hpp), with our messages: no library text reaches the user, no huge allocation is tried.
LoadedImage load_png(const std::string& path) {
  try {
    io::GrayPng png = io::read_png_gray(path, kMaxImageSide);
    return {std::move(png.gray), std::move(png.conversion)};
  } catch (const io::PngError& e) {
    switch (e.kind()) {
      case io::PngError::Kind::too_large:
        throw CliError(too_large_message(path, e.width(), e.height()));
      case io::PngError::Kind::unreadable:
        throw CliError("cannot open image " + quoted(path) + ": " + e.what());
      case io::PngError::Kind::not_png:
        throw CliError("cannot decode image " + quoted(path) + ": " + e.what() +
                       (PORTA_APPS_HAVE_OPENCV ? "" : "; this portaslam was built without OpenCV and reads PNG files only"));
      default:
        throw CliError("cannot decode image " + quoted(path) + ": " + e.what());
    }
  }
}

#if PORTA_APPS_HAVE_OPENCV

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

#endif

}  // namespace

#if PORTA_APPS_HAVE_OPENCV

LoadedImage load_gray_image(const std::string& path) {
  check_readable(path);
  if (io::has_png_signature(path)) return load_png(path);
  cv::Mat decoded;
  try {
    decoded = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw CliError("cannot decode image " + quoted(path) + ": " +
                   (e.code == cv::Error::StsNoMem ? std::string("too large to decode (out of memory)")
                                                  : "corrupt or unsupported (" + e.err + ")"));
  }
  if (decoded.empty())
    throw CliError("cannot decode image " + quoted(path) +
                   ": not an image file OpenCV can read (corrupt, truncated, or not an image)");
  if (decoded.cols > kMaxImageSide || decoded.rows > kMaxImageSide)
    throw CliError(too_large_message(path, decoded.cols, decoded.rows));

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

#else  // without OpenCV: PNG only, through libpng, converted to gray as OpenCV would

LoadedImage load_gray_image(const std::string& path) {
  check_readable(path);
  return load_png(path);
}

#endif

}  // namespace porta::app
