// The C++ side of the Python bindings' tests and overhead benchmark: the cpu (or another) backend's
// Frontend on a stereo pair of PNG files, called as a C++ program calls it.
//
//   porta_frontend_call LEFT.png RIGHT.png [--backend NAME] [--levels N] [--dump DIR] [--repeat N]
//
// --dump writes the bytes of the left and right keypoints and descriptors and of the matches
// (left_keypoints.bin, left_descriptors.bin, right_..., matches.bin) for a byte comparison;
// --repeat N times N calls of detect_stereo after one warm-up and prints the median in
// microseconds ("median_us 1234.5").
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/frontend.hpp"
#include "porta/registry.hpp"
#include "imageio/png_file.hpp"

namespace {

template <typename T>
void write_bytes(const std::string& path, const std::vector<T>& items) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(items.data()), static_cast<std::streamsize>(items.size() * sizeof(T)));
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace

int main(int argc, char** argv) try {
  std::vector<std::string> images;
  std::string backend_name = "cpu", dump;
  int repeat = 0, levels = 8;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--backend" && has_value) backend_name = argv[++i];
    else if (arg == "--dump" && has_value) dump = argv[++i];
    else if (arg == "--repeat" && has_value) repeat = std::stoi(argv[++i]);
    else if (arg == "--levels" && has_value) levels = std::stoi(argv[++i]);
    else images.push_back(arg);
  }
  if (images.size() != 2) {
    std::fprintf(stderr, "usage: porta_frontend_call LEFT.png RIGHT.png [--backend NAME] [--levels N] [--dump DIR] [--repeat N]\n");
    return 2;
  }
  const porta::Image left = porta::io::read_png_gray(images[0], porta::kMaxImageSide).gray;
  const porta::Image right = porta::io::read_png_gray(images[1], porta::kMaxImageSide).gray;
  auto backend = porta::BackendRegistry::instance().create(backend_name);
  porta::FrontendSettings settings;
  settings.levels = levels;
  porta::Frontend frontend(*backend, settings, left.width(), left.height());
  const porta::StereoFeatures pair = frontend.detect_stereo(left.view(), right.view());
  std::printf("keypoints %zu %zu matches %d\n", pair.left.keypoints.size(), pair.right.keypoints.size(),
              pair.num_matches());
  if (!dump.empty()) {
    write_bytes(dump + "/left_keypoints.bin", pair.left.keypoints);
    write_bytes(dump + "/left_descriptors.bin", pair.left.descriptors);
    write_bytes(dump + "/right_keypoints.bin", pair.right.keypoints);
    write_bytes(dump + "/right_descriptors.bin", pair.right.descriptors);
    write_bytes(dump + "/matches.bin", pair.matches);
  }
  if (repeat > 0) {
    std::vector<double> us;
    for (int i = 0; i < repeat; ++i) {
      const auto start = std::chrono::steady_clock::now();
      const porta::StereoFeatures timed = frontend.detect_stereo(left.view(), right.view());
      us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count());
      if (timed.left.keypoints.size() != pair.left.keypoints.size()) throw std::logic_error("results changed");
    }
    std::nth_element(us.begin(), us.begin() + static_cast<std::ptrdiff_t>(us.size() / 2), us.end());
    std::printf("median_us %.1f\n", us[us.size() / 2]);
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "porta_frontend_call: %s\n", e.what());
  return 1;
}
