// Fuzz target: the KITTI reader's text files, calib.txt and times.txt (slam/dataset/kitti_dataset.cpp),
// in a folder whose images are valid: the input is calib.txt, then optionally a form feed and
// times.txt. Opens the dataset and loads a frame. Documented failure: DatasetError.
#include <algorithm>

#include "fuzz_input.hpp"
#include "imageio/png_file.hpp"
#include "porta/slam/dataset.hpp"

namespace {

/// The dataset folder with two 64x48 stereo pairs, made once per process.
const porta::fuzz::fs::path& kitti_folder() {
  static const porta::fuzz::fs::path root = [] {
    const auto root = porta::fuzz::scratch_folder() / "kitti";
    std::vector<std::uint8_t> pixels(64 * 48);
    for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<std::uint8_t>((i * 37) ^ (i >> 3));
    for (const char* side : {"image_0", "image_1"}) {
      porta::fuzz::fs::create_directories(root / side);
      for (const char* name : {"000000.png", "000001.png"})
        porta::io::write_png_gray((root / side / name).string(), 64, 48, pixels.data(), 64);
    }
    return root;
  }();
  return root;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace porta::slam;
  namespace fz = porta::fuzz;
  const auto& root = kitti_folder();
  const std::span<const std::uint8_t> input(data, size);
  const auto split = std::find(input.begin(), input.end(), std::uint8_t{'\f'});
  const std::size_t at = static_cast<std::size_t>(split - input.begin());
  fz::write_input(root / "calib.txt", input.first(at));
  std::error_code ignored;
  fz::fs::remove(root / "times.txt", ignored);
  if (split != input.end()) fz::write_input(root / "times.txt", input.subspan(at + 1));
  try {
    const auto dataset = open_dataset(DatasetKind::kitti, root.string());
    const StereoPair pair = dataset->load(0);
    if (pair.left.width() != 64) __builtin_trap();
  } catch (const DatasetError& e) {
    porta::fuzz::expected(e);
  }
  return 0;
}
