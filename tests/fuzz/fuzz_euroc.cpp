// Fuzz target: the EuRoC reader's files, sensor.yaml and data.csv (slam/dataset/euroc_dataset.cpp),
// in a folder whose images are valid: the input is cam0's sensor.yaml, a form feed, cam1's
// sensor.yaml, then optionally a form feed and data.csv (for both cameras). Opens the dataset (which computes the rectification from
// sensor.yaml) and loads a frame. Documented failure: DatasetError.
#include <algorithm>

#include "fuzz_input.hpp"
#include "imageio/png_file.hpp"
#include "porta/slam/dataset.hpp"

namespace {

constexpr const char* kFrames[] = {"1403715273262142976", "1403715273312143104"};

/// mav0/cam0 and mav0/cam1 with two 64x48 images each, made once per process.
const porta::fuzz::fs::path& euroc_folder() {
  static const porta::fuzz::fs::path root = [] {
    const auto root = porta::fuzz::scratch_folder() / "euroc";
    std::vector<std::uint8_t> pixels(64 * 48);
    for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<std::uint8_t>((i * 53) ^ (i >> 2));
    for (const char* cam : {"cam0", "cam1"}) {
      porta::fuzz::fs::create_directories(root / "mav0" / cam / "data");
      for (const char* t : kFrames)
        porta::io::write_png_gray((root / "mav0" / cam / "data" / (std::string(t) + ".png")).string(), 64, 48,
                                  pixels.data(), 64);
    }
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
  std::span<const std::uint8_t> rest(data, size), parts[3];
  int count = 0;
  for (; count < 3; ++count) {
    const auto split = count < 2 ? std::find(rest.begin(), rest.end(), std::uint8_t{'\f'}) : rest.end();
    const std::size_t at = static_cast<std::size_t>(split - rest.begin());
    parts[count] = rest.first(at);
    if (split == rest.end()) {
      ++count;
      break;
    }
    rest = rest.subspan(at + 1);
  }
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
