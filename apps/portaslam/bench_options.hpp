// Options of `portaslam bench` (the frontend throughput matrix) and their parsing: which backends,
// resolutions, pyramid depths and modes to time, how many frames, and where the images come from.
#pragma once

#include <string>
#include <vector>

namespace porta::app {

/// What one timed call does. detect: Frontend with describe = false; extract: detect + describe;
/// stereo: detect + describe both images of a pair, then stereo matching.
enum class BenchMode { detect, extract, stereo };

const char* mode_name(BenchMode mode);

struct Resolution {
  int width = 0;
  int height = 0;
  std::string text() const;  ///< "640x480"
};

struct BenchOptions {
  std::vector<std::string> backends;  ///< empty = cpu plus every other backend available here
  std::vector<Resolution> resolutions = {{320, 240}, {640, 480}, {752, 480}, {1242, 375}};
  std::vector<int> levels = {1, 4, 8};
  std::vector<BenchMode> modes = {BenchMode::detect, BenchMode::extract, BenchMode::stereo};
  /// Frames kept in flight (FrontendOptions::in_flight); > 1 times throughput, only on backends
  /// with several queues.
  std::vector<int> in_flight = {1};
  /// How images reach the Frontend: false = submit(ImageView), copied on the host into its pinned
  /// staging; true = the same images in InputImages filled once before timing (as a camera writes
  /// its frames there), read by the device in place. Both may be listed.
  std::vector<bool> pinned_input = {false};
  int frames = 200;    ///< timed frames per cell
  int warmup = 20;     ///< untimed frames before them
  int threads = 0;     ///< cpu backend worker threads, 0 = all hardware threads
  std::string device;  ///< device of the non-cpu backends; empty = each backend's default
  bool peer = true;    ///< time OpenCV's cv::ORB on the same images too
  bool profile_kernels = false;  ///< vulkan, opencl: device time per kernel (BackendOptions::profile_kernels)
  std::string json;    ///< write every number there as JSON; empty = no JSON
  std::string data;    ///< --data; empty = $PORTA_DATA_DIR, then ../shared/data
  bool help = false;
};

/// Parses the arguments after "bench"; throws CliError for anything it cannot accept (including
/// a --levels value the engine's FrontendSettings::validate() rejects).
BenchOptions parse_bench_options(const std::vector<std::string>& args);

/// Usage text of `portaslam bench` (also shown by `portaslam bench --help`).
std::string bench_usage();

/// `portaslam bench`: the arguments after "bench"; returns the exit status (0, or 1 with a
/// message on stderr). Declared here rather than in commands.hpp, which belongs to other work.
int bench_command(const std::vector<std::string>& args);

}  // namespace porta::app
