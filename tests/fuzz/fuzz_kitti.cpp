// Fuzz target: the KITTI reader's text files, calib.txt and times.txt (slam/dataset/kitti_dataset.cpp),
// in a folder whose images are valid: the input is calib.txt, then optionally a form feed and
// times.txt. Opens the dataset and loads a frame. Documented failure: DatasetError.
#include "dataset_scaffold.hpp"
#include "porta/slam/dataset.hpp"

namespace {

/// The dataset folder with two 64x48 stereo pairs, made once per process.
const porta::fuzz::fs::path& kitti_folder() {
  static const porta::fuzz::fs::path root = [] {
    const auto root = porta::fuzz::scratch_folder() / "kitti";
    porta::fuzz::write_scaffold_pngs({root / "image_0" / "000000.png", root / "image_0" / "000001.png",
                                      root / "image_1" / "000000.png", root / "image_1" / "000001.png"});
    return root;
  }();
  return root;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace porta::slam;
  namespace fz = porta::fuzz;
  const auto& root = kitti_folder();
  const auto parts = fz::split_at_form_feeds({data, size}, 2);
  fz::write_input(root / "calib.txt", parts[0]);
  std::error_code ignored;
  fz::fs::remove(root / "times.txt", ignored);
  if (parts.size() > 1) fz::write_input(root / "times.txt", parts[1]);
  try {
    const auto dataset = open_dataset(DatasetKind::kitti, root.string());
    const StereoPair pair = dataset->load(0);
    if (pair.left.width() != 64) __builtin_trap();
  } catch (const DatasetError& e) {
    porta::fuzz::expected(e);
  }
  return 0;
}
