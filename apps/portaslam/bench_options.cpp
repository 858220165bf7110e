#include "bench_options.hpp"

#include <algorithm>
#include <sstream>

#include "cli_args.hpp"
#include "porta/frontend.hpp"
#include "porta/settings.hpp"

namespace porta::app {

namespace {

constexpr int kMaxFrames = 1000000;
// Below this no pixel lies `edge` (19) px inside the image, where corners are detected.
constexpr int kMinSide = 40;

// "a,b,,c" -> {"a", "b", "c"}; an empty list is an error naming the option.
std::vector<std::string> split_list(const std::string& option, const std::string& text) {
  std::vector<std::string> items;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty() && std::find(items.begin(), items.end(), item) == items.end()) items.push_back(item);
  if (items.empty()) throw CliError("option " + option + " needs at least one value, got '" + text + "'");
  return items;
}

Resolution parse_resolution(const std::string& option, const std::string& text) {
  const auto x = text.find_first_of("xX");
  const auto digits = [](const std::string& s) {
    return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (x == std::string::npos || !digits(text.substr(0, x)) || !digits(text.substr(x + 1)))
    throw CliError("option " + option +
                   " expects sizes WxH separated by commas (e.g. 640x480,1242x375), got '" + text + "'");
  const Resolution r{parse_int(option, text.substr(0, x)), parse_int(option, text.substr(x + 1))};
  if (std::min(r.width, r.height) < kMinSide || std::max(r.width, r.height) > kMaxImageSide)
    throw CliError("option " + option + ": size " + text + " is out of range: each side must be in [" +
                   std::to_string(kMinSide) + ", " + std::to_string(kMaxImageSide) + "]");
  return r;
}

BenchMode parse_mode(const std::string& text) {
  for (BenchMode m : {BenchMode::detect, BenchMode::extract, BenchMode::stereo})
    if (text == mode_name(m)) return m;
  throw CliError("unknown mode '" + text + "' in --modes: choose from detect, extract, stereo");
}

// The engine's validate() is the one place that knows the allowed pyramid depths.
int parse_levels(const std::string& option, const std::string& text) {
  FrontendSettings settings;
  settings.levels = parse_int(option, text);
  try {
    settings.validate();
  } catch (const SettingsError& e) {
    throw CliError(std::string(e.what()) + " (set by " + option + ")");
  }
  return settings.levels;
}

int parse_count(const std::string& option, const std::string& text, int min) {
  const int n = parse_int(option, text);
  if (n < min || n > kMaxFrames)
    throw CliError("option " + option + " expects a count in [" + std::to_string(min) + ", " +
                   std::to_string(kMaxFrames) + "], got " + text);
  return n;
}

void apply_value(BenchOptions& o, const std::string& option, const std::string& value) {
  if (option == "--backend") {
    o.backends = split_list(option, value);
  } else if (option == "--resolutions") {
    o.resolutions.clear();
    for (const auto& item : split_list(option, value))
      o.resolutions.push_back(parse_resolution(option, item));
  } else if (option == "--levels") {
    o.levels.clear();
    for (const auto& item : split_list(option, value)) o.levels.push_back(parse_levels(option, item));
  } else if (option == "--modes") {
    o.modes.clear();
    for (const auto& item : split_list(option, value)) o.modes.push_back(parse_mode(item));
  } else if (option == "--in-flight") {
    o.in_flight.clear();
    for (const auto& item : split_list(option, value)) {
      const int n = parse_int(option, item);
      if (n < 1 || n > FrontendOptions::kMaxInFlight)
        throw CliError("option --in-flight expects frame counts in [1, " + std::to_string(FrontendOptions::kMaxInFlight) +
                       "], got " + item);
      o.in_flight.push_back(n);
    }
  } else if (option == "--input") {
    o.pinned_input.clear();
    for (const auto& item : split_list(option, value)) {
      if (item != "copy" && item != "pinned")
        throw CliError("unknown input '" + item + "' in --input: choose from copy, pinned");
      o.pinned_input.push_back(item == "pinned");
    }
  } else if (option == "--frames") {
    o.frames = parse_count(option, value, 1);
  } else if (option == "--warmup") {
    o.warmup = parse_count(option, value, 0);
  } else if (option == "--threads") {
    o.threads = parse_threads(option, value);
  } else if (option == "--device") {
    o.device = value;
  } else if (option == "--json") {
    if (value.empty()) throw CliError("option --json needs a file name");
    o.json = value;
  } else if (option == "--data") {
    if (value.empty()) throw CliError("option --data needs a folder");
    o.data = value;
  }
}

bool takes_value(const std::string& option) {
  static const char* const names[] = {"--backend", "--resolutions", "--levels", "--modes",
                                      "--frames",  "--warmup",      "--threads", "--device",
                                      "--json",    "--data",        "--in-flight", "--input"};
  return std::find(std::begin(names), std::end(names), option) != std::end(names);
}

}  // namespace

const char* mode_name(BenchMode mode) {
  switch (mode) {
    case BenchMode::detect:
      return "detect";
    case BenchMode::extract:
      return "extract";
    case BenchMode::stereo:
      return "stereo";
  }
  return "?";
}

std::string Resolution::text() const { return std::to_string(width) + "x" + std::to_string(height); }

BenchOptions parse_bench_options(const std::vector<std::string>& args) {
  BenchOptions options;
  ArgumentCursor cursor(args);
  while (!cursor.done()) {
    const std::string arg = cursor.take();
    if (arg == "--help" || arg == "-h") {
      options.help = true;
    } else if (arg == "--no-peer") {
      if (cursor.has_inline_value()) throw CliError("option --no-peer takes no value");
      options.peer = false;
    } else if (arg == "--profile-kernels") {
      if (cursor.has_inline_value()) throw CliError("option --profile-kernels takes no value");
      options.profile_kernels = true;
    } else if (takes_value(arg)) {
      apply_value(options, arg, cursor.value(arg));
    } else if (arg.size() > 1 && arg[0] == '-') {
      throw CliError("unknown option '" + arg + "' (see `portaslam bench --help`)");
    } else {
      throw CliError("unexpected argument '" + arg +
                     "': bench takes options only (see `portaslam bench --help`)");
    }
  }
  return options;
}

std::string bench_usage() {
  return "Usage: portaslam bench [OPTIONS]\n"
         "\n"
         "Times the feature frontend over a matrix of resolutions x pyramid levels x modes on one or\n"
         "more backends, and OpenCV's cv::ORB on the CPU on the same images as a peer. Per cell it\n"
         "prints the median, p10 and p90 time per frame (wall time of one Frontend call: upload,\n"
         "kernels, synchronisation, download), frames/s, mean keypoints, and our speed-up over the peer.\n"
         "Images: KITTI 07 and EuRoC V1_01 frames from the shared data folder, or a built-in synthetic\n"
         "image when it is absent. A full default run takes minutes; progress goes to stderr.\n"
         "\n"
         "  --backend LIST       backends to time, e.g. cpu,opencl (default: cpu and every other\n"
         "                       backend available here; see `portaslam backends`)\n"
         "  --resolutions LIST   sizes WxH (default 320x240,640x480,752x480,1242x375)\n"
         "  --levels LIST        pyramid levels, each in [1, 12] (default 1,4,8)\n"
         "  --modes LIST         detect, extract (detect + describe), stereo (both images + matching)\n"
         "                       (default detect,extract,stereo)\n"
         "  --in-flight LIST     frames kept in flight, each in [1, 16] (default 1): with N > 1 a row\n"
         "                       times throughput, the interval between frames completing while N\n"
         "                       are submitted and not yet collected (label BACKEND/N); only backends\n"
         "                       with several queues (cuda) get such rows\n"
         "  --input LIST         how images reach the frontend (default copy): copy = the host copies\n"
         "                       each into pinned staging; pinned = they already lie in pinned input\n"
         "                       images (filled once, as a camera writes its frames), read in place\n"
         "                       by the device (label BACKEND+pin)\n"
         "  --frames N           timed frames per cell, [1, 1000000] (default 200)\n"
         "  --warmup W           untimed frames before them, [0, 1000000] (default 20)\n"
         "  --threads N          cpu backend worker threads, 0 = all hardware threads (default 0)\n"
         "  --device D           device index or name substring of the non-cpu backends\n"
         "  --no-peer            do not time OpenCV's cv::ORB\n"
         "  --profile-kernels    vulkan and opencl: also time every dispatch on the device (timestamp\n"
         "                       queries, profiling events) and print each row's time per kernel and\n"
         "                       frame; the timing adds host work, so compare frame times without it\n"
         "  --json FILE          also write every number, the machine, date and commit as JSON\n"
         "  --data DIR           the shared data folder (default: $PORTA_DATA_DIR, else ../shared/data\n"
         "                       from the current folder, else from the source tree)\n"
         "\n"
         "Exit status: 0 success; 1 bad option, value or backend, or a failed run (message on stderr).\n"
#if !PORTA_APPS_HAVE_OPENCV
         "\n"
         "This portaslam was built without OpenCV C++: the cv::ORB peer is not built (the header says\n"
         "so); bench/orb_peer.py --ours FILE.json times cv2.ORB from Python on the same images instead.\n"
#endif
      ;
}

}  // namespace porta::app
