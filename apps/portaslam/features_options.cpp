#include "features_options.hpp"

#include <functional>
#include <map>
#include <sstream>

#include "cli_args.hpp"
#include "commands.hpp"

namespace porta::app {

namespace {

struct SettingOption {
  const char* field;  // as named by FrontendSettings::validate()'s messages
  std::function<void(FeaturesOptions&, const std::string& option, const std::string& value)> apply;
};

// One entry per option that takes a value; the flag --no-pfa is handled apart.
const std::map<std::string, SettingOption>& value_options() {
  static const std::map<std::string, SettingOption> options = {
      {"--backend", {"", [](auto& o, auto&, auto& v) { o.backend = v; }}},
      {"--device", {"", [](auto& o, auto&, auto& v) { o.device = v; }}},
      {"--threads", {"", [](auto& o, auto& n, auto& v) { o.threads = parse_threads(n, v); }}},
      {"--out", {"", [](auto& o, auto&, auto& v) { o.out = v; }}},
      {"--dump", {"", [](auto& o, auto&, auto& v) {
                     if (v.empty()) throw CliError("option --dump needs a file name");
                     o.dump = v;
                   }}},
      {"--repeat", {"", [](auto& o, auto& n, auto& v) { o.repeat = parse_int(n, v); }}},
      {"--levels", {"levels", [](auto& o, auto& n, auto& v) { o.settings.levels = parse_int(n, v); }}},
      {"--scale", {"scale_factor", [](auto& o, auto& n, auto& v) { o.settings.scale_factor = parse_double(n, v); }}},
      {"--threshold", {"fast_threshold", [](auto& o, auto& n, auto& v) { o.settings.fast_threshold = parse_int(n, v); }}},
      {"--min-arc", {"min_arc", [](auto& o, auto& n, auto& v) { o.settings.min_arc = parse_int(n, v); }}},
      {"--max-arc", {"max_arc", [](auto& o, auto& n, auto& v) { o.settings.max_arc = parse_int(n, v); }}},
      {"--cell", {"cell_width", [](auto& o, auto& n, auto& v) {
                    o.settings.cell_width = parse_int(n, v);
                    o.settings.cell_height = o.settings.cell_width;
                  }}},
      {"--max-disparity", {"stereo_max_disparity", [](auto& o, auto& n, auto& v) {
                             o.settings.stereo_max_disparity = parse_int(n, v);
                           }}},
      {"--min-disparity", {"stereo_min_disparity", [](auto& o, auto& n, auto& v) {
                             o.settings.stereo_min_disparity = parse_int(n, v);
                           }}},
      {"--max-hamming", {"stereo_max_hamming", [](auto& o, auto& n, auto& v) {
                           o.settings.stereo_max_hamming = parse_int(n, v);
                         }}},
      {"--edge", {"edge", [](auto& o, auto& n, auto& v) { o.settings.edge = parse_int(n, v); }}},
      {"--pfa-window", {"pfa_window", [](auto& o, auto& n, auto& v) { o.settings.pfa_window = parse_int(n, v); }}},
      {"--orientation-bins", {"orientation_bins", [](auto& o, auto& n, auto& v) {
                                o.settings.orientation_bins = parse_int(n, v);
                              }}},
  };
  return options;
}

}  // namespace

std::string option_for_setting_field(const std::string& field) {
  if (field.empty()) return "";
  if (field == "cell_height") return "--cell";
  for (const auto& [name, option] : value_options())
    if (field == option.field) return name;
  if (field == "pfa") return "--no-pfa";
  return "";
}

FeaturesOptions parse_features_options(const std::vector<std::string>& args) {
  FeaturesOptions options;
  ArgumentCursor cursor(args);
  while (!cursor.done()) {
    const std::string arg = cursor.take();
    if (arg == "--help" || arg == "-h") {
      options.help = true;
      continue;
    }
    if (arg == "--no-pfa") {
      if (cursor.has_inline_value()) throw CliError("option --no-pfa takes no value");
      options.settings.pfa = false;
      continue;
    }
    const auto it = value_options().find(arg);
    if (it != value_options().end()) {
      it->second.apply(options, arg, cursor.value(arg));
      continue;
    }
    if (arg.size() > 1 && arg[0] == '-')
      throw CliError("unknown option '" + arg + "' (see `portaslam features --help`)");
    options.images.push_back(arg);
  }
  if (options.images.size() > 2)
    throw CliError("too many images: expected IMAGE or LEFT RIGHT, got " + std::to_string(options.images.size()) +
                   " (the third is '" + options.images[2] + "')");
  if (options.repeat < 1 || options.repeat > 10000)
    throw CliError("option --repeat expects a count in [1, 10000], got " + std::to_string(options.repeat));
  if (options.out.empty()) throw CliError("option --out needs a file name");
  return options;
}

std::string features_usage() {
  const FrontendSettings d;
  std::ostringstream u;
  u << "Usage: portaslam features [IMAGE [RIGHT_IMAGE]] [OPTIONS]\n"
       "\n"
       "Detects ORB features on every pyramid level of IMAGE (or of a rectified stereo pair LEFT RIGHT,\n"
       "then matches left against right), prints keypoints per level, stereo matches and per-stage\n"
       "times, and writes an annotated PNG. With no IMAGE it uses a built-in synthetic stereo pair\n"
       "(640x480, known disparities) and reports how many matches have the right disparity.\n"
#if PORTA_APPS_HAVE_OPENCV
       "Color images are converted to gray. Any format OpenCV reads (PNG, JPEG, PGM, ...).\n"
#else
       "Color images are converted to gray. PNG only: this portaslam was built without OpenCV, and\n"
       "its picture is a simple one (keypoints as crosses coloured by level).\n"
#endif
       "\n"
       "Run:\n"
       "  --backend NAME       cpu, cuda, vulkan or opencl (default cpu; see `portaslam backends`)\n"
       "  --device D           device index or name substring (default: the backend's first)\n"
       "  --threads N          cpu backend worker threads, 0 = all hardware threads (default 0)\n"
       "  --repeat N           time N runs after one warm-up run and report medians (default 1)\n"
       "  --out FILE.png       annotated image to write (default features.png)\n"
       "  --dump FILE          also write every keypoint, descriptor and stereo match as text, in\n"
       "                       canonical order (compare two runs with cmp; format in docs/USER_GUIDE.md)\n"
       "Frontend settings (docs/ARCHITECTURE.md gives each one's exact meaning):\n"
       "  --levels N           pyramid levels, [1, 12] (default " << d.levels << ")\n"
       "  --scale S            pyramid scale factor, (1, 2] (default " << d.scale_factor << ")\n"
       "  --threshold E        FAST threshold epsilon, [1, 254] (default " << d.fast_threshold << ")\n"
       "  --min-arc P          shortest accepted FAST arc, [1, 16] (default " << d.min_arc << ")\n"
       "  --max-arc P          longest accepted FAST arc, [min-arc, 16]; 16 = classic FAST (default "
    << d.max_arc << ")\n"
       "  --cell N             level-0 culling cell size in px, [1, 1024] (default " << d.cell_width << ")\n"
       "  --edge N             border skipped by detection, [19, 255] (default " << d.edge << ")\n"
       "  --no-pfa             turn pyramidal feature aggregation off (default on)\n"
       "  --pfa-window Q       PFA window, odd, [1, 15] (default " << d.pfa_window << ")\n"
       "  --orientation-bins B orientation bins, [4, 64] (default " << d.orientation_bins << ")\n"
       "  --min-disparity D    smallest stereo disparity in level-0 px, [0, max-disparity) (default "
    << d.stereo_min_disparity << ")\n"
       "  --max-disparity D    largest stereo disparity in level-0 px, (min-disparity, 4096] (default "
    << d.stereo_max_disparity << ")\n"
       "  --max-hamming H      a stereo match's descriptor distance must be below H, [1, 256] (default "
    << d.stereo_max_hamming << ")\n"
       "\n"
       "Exit status: 0 success; 1 bad option, value, setting, image or backend (message on stderr).\n";
  return u.str();
}

}  // namespace porta::app
