// Detects ORB features on a PNG image with any backend of an installed PortaSLAM; with a second
// (right) image of a rectified pair, matches them too.
//
//   detect_features LEFT.png [RIGHT.png] [--backend NAME]
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>

#include "porta/frontend.hpp"
#include "porta/imageio/png_file.hpp"
#include "porta/registry.hpp"

namespace {
porta::Image read_gray(const std::string& path) try {
  return porta::io::read_png_gray(path, porta::kMaxImageSide).gray;
} catch (const porta::io::PngError& e) {
  throw std::runtime_error(path + ": " + e.what());
}
}  // namespace

int main(int argc, char** argv) try {
  std::string backend_name = "cpu", left_path, right_path;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--backend" && i + 1 < argc) {
      backend_name = argv[++i];
    } else if (left_path.empty()) {
      left_path = arg;
    } else {
      right_path = arg;
    }
  }
  if (left_path.empty()) {
    std::fprintf(stderr, "usage: detect_features LEFT.png [RIGHT.png] [--backend NAME]\n");
    return 2;
  }
  const porta::Image left = read_gray(left_path);
  auto backend = porta::BackendRegistry::instance().create(backend_name);
  porta::Frontend frontend(*backend, porta::FrontendSettings{}, left.width(), left.height());

  if (right_path.empty()) {
    const porta::Features features = frontend.detect(left.view());
    std::printf("%s on %s: %zu keypoints\n", backend->name().c_str(), backend->device_name().c_str(),
                features.keypoints.size());
  } else {
    const porta::Image right = read_gray(right_path);
    const porta::StereoFeatures pair = frontend.detect_stereo(left.view(), right.view());
    std::printf("%s on %s: %zu / %zu keypoints, %d stereo matches\n", backend->name().c_str(),
                backend->device_name().c_str(), pair.left.keypoints.size(), pair.right.keypoints.size(),
                pair.num_matches());
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "detect_features: %s\n", e.what());
  return 1;
}
