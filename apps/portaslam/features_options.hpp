// Options of `portaslam features` and their parsing. Frontend settings are copied into a
// porta::FrontendSettings unchecked: the engine's validate() is the one place that knows the
// allowed ranges, so the CLI never disagrees with it.
#pragma once

#include <string>
#include <vector>

#include "porta/settings.hpp"

namespace porta::app {

struct FeaturesOptions {
  std::vector<std::string> images;    ///< none (built-in pair), one, or a left/right pair
  std::string backend = "cpu";
  std::string device;                 ///< empty = the backend's default device
  int threads = 0;                    ///< cpu backend worker threads, 0 = all hardware threads
  std::string out = "features.png";
  std::string dump;                   ///< text file of every keypoint, descriptor and match; empty = none
  int repeat = 1;                     ///< timed runs; >1 adds a warm-up run and reports medians
  FrontendSettings settings;
  bool help = false;
};

/// Parses the arguments after "features"; throws CliError for anything it cannot accept.
FeaturesOptions parse_features_options(const std::vector<std::string>& args);

/// The command-line option that sets a FrontendSettings field ("fast_threshold" -> "--threshold"),
/// or empty when no option sets it.
std::string option_for_setting_field(const std::string& field);

}  // namespace porta::app
