// `portaslam features`: runs the feature frontend (DESIGN.md §3) on one image or a rectified
// stereo pair with any backend, prints what it found and how long each stage took, and writes an
// annotated PNG (drawn with OpenCV; without OpenCV a plain one, written with libpng). With no image
// it runs on a built-in synthetic pair with known disparities.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#if PORTA_APPS_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "annotate.hpp"
#else
#include <cctype>

#include "imageio/png_file.hpp"
#include "plain_picture.hpp"
#endif

#include "cli_args.hpp"
#include "output_paths.hpp"
#include "commands.hpp"
#include "features_dump.hpp"
#include "features_options.hpp"
#include "image_files.hpp"
#include "porta/frontend.hpp"
#include "porta/registry.hpp"
#include "porta/slam/atomic_file.hpp"
#include "synthetic_pair.hpp"

namespace porta::app {

namespace {

// The images to run on, from files or the built-in pair.
struct Inputs {
  Image left;
  std::optional<Image> right;
  std::optional<SyntheticStereoPair> synthetic;  // set for the built-in pair (known disparities)
  std::string description;
};

Inputs load_inputs(const FeaturesOptions& options) {
  Inputs in;
  if (options.images.empty()) {
    SyntheticStereoPair pair = make_synthetic_stereo_pair();
    in.description = pair.description + "\n          (give IMAGE or LEFT RIGHT to run on your own images)";
    in.left = pair.left;
    in.right = pair.right;
    in.synthetic = std::move(pair);
    return in;
  }
  LoadedImage left = load_gray_image(options.images[0]);
  in.description = options.images[0];
  if (!left.conversion.empty()) in.description += " (converted: " + left.conversion + ")";
  in.left = std::move(left.gray);
  if (options.images.size() == 2) {
    LoadedImage right = load_gray_image(options.images[1]);
    if (right.gray.width() != in.left.width() || right.gray.height() != in.left.height())
      throw CliError("left and right images differ in size: '" + options.images[0] + "' is " +
                     std::to_string(in.left.width()) + "x" + std::to_string(in.left.height()) + ", '" +
                     options.images[1] + "' is " + std::to_string(right.gray.width()) + "x" +
                     std::to_string(right.gray.height()) + "; a rectified stereo pair must have one size");
    in.description += "\n          " + options.images[1];
    if (!right.conversion.empty()) in.description += " (converted: " + right.conversion + ")";
    in.right = std::move(right.gray);
  }
  return in;
}

// The result of one frontend call, single or stereo.
struct RunResult {
  StereoFeatures stereo;  // for a single image only `stereo.left` is filled
  StageTimes times;
};

RunResult run_once(Frontend& frontend, const Inputs& in) {
  RunResult r;
  if (in.right)
    r.stereo = frontend.detect_stereo(in.left.view(), in.right->view());
  else
    r.stereo.left = frontend.detect(in.left.view());
  r.times = frontend.last_times();
  return r;
}

// Stage-wise medians: each stage's own median (stages do not add up to the median total exactly).
StageTimes median_times(std::vector<StageTimes> runs) {
  StageTimes out;
  auto median_of = [&](std::int64_t StageTimes::*field) {
    std::vector<std::int64_t> v;
    for (const auto& r : runs) v.push_back(r.*field);
    std::sort(v.begin(), v.end());
    out.*field = v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
  };
  for (auto field : {&StageTimes::upload_ns, &StageTimes::pyramid_ns, &StageTimes::fast_ns, &StageTimes::cull_ns,
                     &StageTimes::pfa_ns, &StageTimes::orient_ns, &StageTimes::blur_ns, &StageTimes::describe_ns,
                     &StageTimes::stereo_ns, &StageTimes::download_ns, &StageTimes::total_ns})
    median_of(field);
  return out;
}

std::string percent(long part, long whole) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f%%", whole > 0 ? 100.0 * static_cast<double>(part) / whole : 0.0);
  return text;
}

void print_settings(const FrontendSettings& s, bool stereo) {
  std::printf("settings  levels %d, scale %g, threshold %d, arc [%d, %d], edge %d, cell %dx%d, pfa %s", s.levels,
              s.scale_factor, s.fast_threshold, s.min_arc, s.max_arc, s.edge, s.cell_width, s.cell_height,
              s.pfa ? "on" : "off");
  if (s.pfa) std::printf(" (window %d)", s.pfa_window);
  std::printf(", orientation bins %d\n", s.orientation_bins);
  if (stereo)
    std::printf("          disparity [%d, %d] px, max hamming %d\n", s.stereo_min_disparity, s.stereo_max_disparity,
                s.stereo_max_hamming);
}

void print_level_table(const RunResult& r, const FrontendTables& tables, bool stereo) {
  std::printf("\nkeypoints per level%s\n", stereo ? " (left and right image)" : "");
  std::printf("level  scale   size        %s\n", stereo ? " left  right" : "keypoints");
  for (int level = 0; level < tables.settings.levels; ++level) {
    const auto [w, h] = tables.level_sizes[static_cast<std::size_t>(level)];
    char size[32];
    std::snprintf(size, sizeof size, "%dx%d", w, h);
    std::printf("%5d  %5.3f   %-11s %5d", level, tables.scales_q16[static_cast<std::size_t>(level)] / 65536.0, size,
                r.stereo.left.keypoints_per_level[static_cast<std::size_t>(level)]);
    if (stereo) std::printf("  %5d", r.stereo.right.keypoints_per_level[static_cast<std::size_t>(level)]);
    std::printf("\n");
  }
  std::printf("total                     %6zu", r.stereo.left.keypoints.size());
  if (stereo) std::printf("  %5zu", r.stereo.right.keypoints.size());
  std::printf(" keypoints\n");
}

// Of the matched left keypoints, how many have the built-in pair's true disparity within 1 px.
long count_correct_disparities(const RunResult& r, const FrontendTables& tables, const SyntheticStereoPair& pair) {
  long correct = 0;
  for (std::size_t i = 0; i < r.stereo.matches.size(); ++i) {
    const StereoMatch& m = r.stereo.matches[i];
    if (m.disparity_q8 < 0) continue;
    const int x = std::clamp(static_cast<int>(std::lround(r.stereo.left.level0_x(i, tables))), 0, pair.left.width() - 1);
    const int y = std::clamp(static_cast<int>(std::lround(r.stereo.left.level0_y(i, tables))), 0, pair.left.height() - 1);
    if (std::abs(m.disparity_q8 / 256.0 - pair.disparity_at(x, y)) <= 1.0) ++correct;
  }
  return correct;
}

void print_times(const StageTimes& t, int repeat, bool stereo) {
  if (repeat > 1)
    std::printf("\nstage times in ms (median of %d runs after 1 warm-up run):\n", repeat);
  else
    std::printf("\nstage times in ms (one cold run; --repeat N gives the median of N runs after a warm-up):\n");
  auto line = [](const char* name, std::int64_t ns) { std::printf("  %-9s %9.3f\n", name, ns / 1e6); };
  line("upload", t.upload_ns);
  line("pyramid", t.pyramid_ns);
  line("fast", t.fast_ns);
  line("cull", t.cull_ns);
  line("pfa", t.pfa_ns);
  line("orient", t.orient_ns);
  line("blur", t.blur_ns);
  line("describe", t.describe_ns);
  if (stereo) line("stereo", t.stereo_ns);
  line("download", t.download_ns);
  line("total", t.total_ns);
}

#if PORTA_APPS_HAVE_OPENCV
bool have_image_writer(const std::string& path) { return cv::haveImageWriter(path); }
#else
bool have_image_writer(const std::string& path) {  // libpng: a name ending in .png, any case
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension == ".png";
}
#endif

// Checked before any work so that a typo in --out does not cost a whole run.
void check_output_path(const std::string& path) {
  if (!have_image_writer(path))
    throw CliError("cannot write '" + path + "': no image writer for that file name (use a name ending in .png)");
  check_output_file("--out", path);
}

#if PORTA_APPS_HAVE_OPENCV

void write_png(const std::string& path, const cv::Mat& image) {
  // Encoded in memory, then written whole or not at all (atomic_file.hpp).
  std::vector<std::uint8_t> bytes;
  bool encoded = false;
  try {
    encoded = cv::imencode(std::filesystem::path(path).extension().string(), image, bytes);
  } catch (const cv::Exception& e) {
    throw CliError("cannot write '" + path + "': " + e.err + " (use a file name ending in .png)");
  }
  if (!encoded) throw CliError("cannot write '" + path + "': encoding failed (use a file name ending in .png)");
  try {
    slam::write_file_atomically(path, bytes);
  } catch (const slam::AtomicWriteError& e) {
    throw CliError(e.what());
  }
}

// Draws the result and writes it; returns the line that says what was written.
std::string write_picture(const std::string& path, const Inputs& in, const RunResult& result,
                          const FrontendTables& tables) {
  const bool stereo = in.right.has_value();
  cv::Mat annotated;
  if (stereo) {
    KnownDisparity known;
    if (in.synthetic) known = {&in.synthetic->disparity_px, in.synthetic->left.width()};
    annotated = draw_stereo(in.left, *in.right, result.stereo, tables, known);
  } else {
    annotated = draw_features(in.left, result.stereo.left, tables);
  }
  write_png(path, annotated);
  return "wrote " + path + " (" + std::to_string(annotated.cols) + "x" + std::to_string(annotated.rows) + "): " +
         (stereo ? "left | right with keypoints and sample match lines; below, matches coloured by disparity"
                 : "keypoints coloured by level, tick = orientation");
}

#else

std::string write_picture(const std::string& path, const Inputs& in, const RunResult& result,
                          const FrontendTables& tables) {
  const bool stereo = in.right.has_value();
  const RgbPicture picture = stereo ? plain_stereo(in.left, *in.right, result.stereo, tables)
                                    : plain_features(in.left, result.stereo.left, tables);
  try {
    io::write_png_rgb(path, picture.width, picture.height, picture.rgb.data(),
                      static_cast<std::size_t>(picture.width) * 3);
  } catch (const io::PngError& e) {
    throw CliError("cannot write '" + path + "': " + e.what() + " (check that its folder is writable)");
  }
  return "wrote " + path + " (" + std::to_string(picture.width) + "x" + std::to_string(picture.height) + "): " +
         (stereo ? "left | right, " : "") +
         "keypoints as crosses coloured by level (a plain picture: this portaslam was built without OpenCV)";
}

#endif

int run(const FeaturesOptions& options) {
  options.settings.validate();
  check_output_path(options.out);
  if (!options.dump.empty()) check_output_file("--dump", options.dump);
  const Inputs in = load_inputs(options);

  BackendOptions backend_options;
  backend_options.device = options.device;
  backend_options.threads = options.threads;
  std::unique_ptr<Backend> backend = BackendRegistry::instance().create(options.backend, backend_options);

  FrontendOptions frontend_options;
  frontend_options.describe = true;
  frontend_options.profile_stages = true;
  Frontend frontend(*backend, options.settings, in.left.width(), in.left.height(), frontend_options);
  const FrontendTables& tables = frontend.tables();
  const bool stereo = in.right.has_value();

  std::printf("input     %s\n", in.description.c_str());
  std::printf("backend   %s on %s\n", backend->name().c_str(), backend->device_name().c_str());
  std::printf("image     %dx%d, %s\n", in.left.width(), in.left.height(), stereo ? "stereo pair" : "single image");
  print_settings(options.settings, stereo);
  std::fflush(stdout);

  if (options.repeat > 1) run_once(frontend, in);  // warm-up: first-use costs stay out of the medians
  RunResult result;
  std::vector<StageTimes> times;
  for (int i = 0; i < options.repeat; ++i) {
    result = run_once(frontend, in);
    times.push_back(result.times);
  }

  print_level_table(result, tables, stereo);
  if (stereo) {
    const long left_count = static_cast<long>(result.stereo.left.keypoints.size());
    const long matches = result.stereo.num_matches();
    std::printf("\nstereo matches: %ld of %ld left keypoints (%s)\n", matches, left_count,
                percent(matches, left_count).c_str());
    if (in.synthetic) {
      const long correct = count_correct_disparities(result, tables, *in.synthetic);
      std::printf("known disparity within 1 px: %ld of %ld matches (%s)\n", correct, matches,
                  percent(correct, matches).c_str());
    }
  }
  print_times(median_times(times), options.repeat, stereo);

  std::printf("\n%s\n", write_picture(options.out, in, result, tables).c_str());
  if (!options.dump.empty()) {
    try {
      slam::write_file_atomically(options.dump,
                                  features_dump_text(result.stereo, in.left.width(), in.left.height(), stereo));
    } catch (const slam::AtomicWriteError& e) {
      throw CliError(e.what());
    }
    std::printf("wrote %s: every keypoint, descriptor and stereo match as text\n", options.dump.c_str());
  }
  return 0;
}

// Names the option that sets a rejected field, so "invalid setting fast_threshold = 0" points the
// user at --threshold.
std::string with_option_hint(const std::string& message) {
  const std::string prefix = "invalid setting ";
  if (message.rfind(prefix, 0) != 0) return message;
  const std::string field = message.substr(prefix.size(), message.find(' ', prefix.size()) - prefix.size());
  const std::string option = option_for_setting_field(field);
  return option.empty() ? message : message + " (set by " + option + ")";
}

}  // namespace

int features_command(const std::vector<std::string>& args) {
  const char* const who = "portaslam features: ";
  try {
    const FeaturesOptions options = parse_features_options(args);
    if (options.help) {
      std::cout << features_usage();
      return 0;
    }
    return run(options);
  } catch (const SettingsError& e) {
    std::cerr << who << with_option_hint(e.what()) << '\n';
  } catch (const BackendError& e) {
    std::cerr << who << e.what() << "\n(`portaslam backends` lists what this binary has and can use)\n";
  } catch (const CliError& e) {
    std::cerr << who << e.what() << '\n';
  } catch (const std::exception& e) {
    std::cerr << who << "failed: " << e.what() << '\n';
  }
  return 1;
}

}  // namespace porta::app
