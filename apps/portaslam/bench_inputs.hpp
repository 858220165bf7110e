// The images `portaslam bench` times the frontend on: real KITTI 07 and EuRoC V1_01 frames from the
// shared data folder, fitted to each benchmark resolution, or the built-in synthetic pair when no
// data is found. Several distinct frames per resolution, cycled, so caches are not artificially warm.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "bench_options.hpp"
#include "porta/image.hpp"

namespace porta::app {

/// Where the shared data folder is, and how it was found.
struct DataFolder {
  std::filesystem::path path;  ///< empty when none was found
  std::string origin;          ///< "--data", "$PORTA_DATA_DIR", "the current folder's ../shared/data", ...
};

/// --data DIR when given, else $PORTA_DATA_DIR when set (each must be a folder: CliError
/// otherwise), else ../shared/data from the current folder, else from the source tree, else none.
DataFolder locate_data_folder(const std::string& cli_value);

/// The frames of one resolution: 8-bit gray, packed (pitch = width), all of the requested size.
struct BenchFrames {
  std::vector<Image> left;
  std::vector<Image> right;  ///< right[i] is the "right image" of left[i] (timing only)
  std::string source;          ///< what they are and how they were fitted to the size, in words
  bool synthetic = false;
};

/// 752x480 (EuRoC's own size): EuRoC cam0/cam1 pairs as recorded. Any other size: KITTI 07 left
/// frames (the next frame as the "right" image), else EuRoC, else the built-in synthetic pair in 8
/// row-rolled variants; each centre-cropped to the size's aspect ratio, then resized to it (with
/// cv::resize, or without OpenCV with plain_resize.hpp's equivalent of it).
BenchFrames load_bench_frames(const DataFolder& data, Resolution size);

}  // namespace porta::app
