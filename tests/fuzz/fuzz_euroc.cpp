// Fuzz target: the EuRoC reader's files, sensor.yaml and data.csv (slam/dataset/euroc_dataset.cpp),
// in a folder whose images are valid: the input is cam0's sensor.yaml, a form feed, cam1's
// sensor.yaml, then optionally a form feed and data.csv (for both cameras). Opens the dataset (which computes the rectification from
// sensor.yaml) and loads a frame. Documented failure: DatasetError.
#include "dataset_scaffold.hpp"
#include "porta/slam/dataset.hpp"

namespace {

constexpr const char* kFrames[] = {"1403715273262142976", "1403715273312143104"};

/// mav0/cam0 and mav0/cam1 with two 64x48 images each, made once per process.
const porta::fuzz::fs::path& euroc_folder() {
  static const porta::fuzz::fs::path root = [] {
    const auto root = porta::fuzz::scratch_folder() / "euroc";
    std::vector<porta::fuzz::fs::path> images;
    for (const char* cam : {"cam0", "cam1"})
      for (const char* t : kFrames) images.push_back(root / "mav0" / cam / "data" / (std::string(t) + ".png"));
    porta::fuzz::write_scaffold_pngs(images);
    return root;
  }();
  return root;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace porta::slam;
  namespace fz = porta::fuzz;
  const auto& root = euroc_folder();
  // Up to three parts separated by form feeds: cam0 sensor.yaml, cam1 sensor.yaml, data.csv.
  const auto parts = fz::split_at_form_feeds({data, size}, 3);
  const std::size_t count = parts.size();
  std::string csv = "#timestamp [ns],filename\n";
  for (const char* t : kFrames) csv += std::string(t) + "," + t + ".png\n";
  const std::span<const std::uint8_t> default_csv(reinterpret_cast<const std::uint8_t*>(csv.data()), csv.size());
  fz::write_input(root / "mav0" / "cam0" / "sensor.yaml", parts[0]);
  fz::write_input(root / "mav0" / "cam1" / "sensor.yaml", count > 1 ? parts[1] : parts[0]);
  for (const char* cam : {"cam0", "cam1"})
    fz::write_input(root / "mav0" / cam / "data.csv", count > 2 ? parts[2] : default_csv);
  try {
    const auto dataset = open_dataset(DatasetKind::euroc, root.string());
    (void)dataset->load(0);
  } catch (const DatasetError& e) {
    porta::fuzz::expected(e);
  }
  return 0;
}
