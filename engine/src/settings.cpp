#include "porta/settings.hpp"

#include <sstream>

namespace porta {

namespace {

[[noreturn]] void reject(const char* field, const std::string& value, const std::string& range) {
  std::ostringstream msg;
  msg << "invalid setting " << field << " = " << value << ": allowed " << range;
  throw SettingsError(msg.str());
}

void check_int(const char* field, int value, int lo, int hi) {
  if (value < lo || value > hi)
    reject(field, std::to_string(value), "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

}  // namespace

void FrontendSettings::validate() const {
  check_int("levels", levels, 1, 12);
  if (!(scale_factor > 1.0 && scale_factor <= 2.0)) {
    std::ostringstream v;
    v << scale_factor;
    reject("scale_factor", v.str(), "(1, 2]");
  }
  check_int("fast_threshold", fast_threshold, 1, 254);
  check_int("min_arc", min_arc, 1, 16);
  check_int("max_arc", max_arc, min_arc, 16);
  check_int("edge", edge, 19, 255);
  check_int("cell_width", cell_width, 1, 1024);
  check_int("cell_height", cell_height, 1, 1024);
  check_int("pfa_window", pfa_window, 1, 15);
  if (pfa_window % 2 == 0) reject("pfa_window", std::to_string(pfa_window), "odd values in [1, 15]");
  check_int("orientation_bins", orientation_bins, 4, 64);
  check_int("stereo_max_disparity", stereo_max_disparity, 1, 4096);
  check_int("stereo_min_disparity", stereo_min_disparity, 0, stereo_max_disparity - 1);
  check_int("stereo_max_hamming", stereo_max_hamming, 1, 256);
}

}  // namespace porta
