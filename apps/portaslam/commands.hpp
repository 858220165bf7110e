// The subcommands of the portaslam program. Each takes the arguments after its own name and
// returns the process exit status: 0 success, 1 a problem with the input (message on stderr).
#pragma once

#include <string>
#include <vector>

namespace porta::app {

int backends_command(const std::vector<std::string>& args);
int features_command(const std::vector<std::string>& args);

/// `portaslam render`: renders a stereo sequence with exact ground truth (slam/render).
int render_command(const std::vector<std::string>& args);
std::string render_usage();
/// `portaslam eval`: evaluates an estimated trajectory against ground truth (slam/eval).
int eval_command(const std::vector<std::string>& args);
std::string eval_usage();

/// `portaslam run`: stereo SLAM over a dataset (slam/); `portaslam demo`: render, then run.
int run_command(const std::vector<std::string>& args);
std::string run_usage();
int demo_command(const std::vector<std::string>& args);
std::string demo_usage();

/// `portaslam map info FILE`: describes and checks a saved map file (slam/map_file.hpp).
int map_command(const std::vector<std::string>& args);
std::string map_usage();

/// Usage text of `portaslam features` (also shown by `portaslam features --help`).
std::string features_usage();

}  // namespace porta::app
