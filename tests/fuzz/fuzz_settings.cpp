// Fuzz target: ORB-SLAM2-style YAML settings files (slam/dataset/settings_file.cpp) through to the
// camera and frontend settings they give. Documented failure: SettingsFileError.
#include "fuzz_input.hpp"
#include "porta/slam/settings_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace porta::slam;
  const std::string path = porta::fuzz::write_input(porta::fuzz::scratch_folder() / "settings.yaml",
                                                    porta::fuzz::as_span(data, size));
  try {
    const SettingsFile settings = read_settings_file(path);
    settings.check_rectification_complete();
    (void)settings.stereo_camera();
  } catch (const SettingsFileError& e) {
    porta::fuzz::expected(e);
  }
  return 0;
}
