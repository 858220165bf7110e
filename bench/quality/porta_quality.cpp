// porta_quality: measures PortaSLAM's feature quality on real third-party data (../shared/data)
// and prints a markdown report (docs/QUALITY.md holds one, with the command that produced it):
// corner repeatability and descriptor matching on the Oxford affine sets against OpenCV, and
// sparse stereo accuracy on Middlebury. Progress goes to stderr.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "porta/registry.hpp"
#include "quality/experiments.hpp"
#include "quality/quality_data.hpp"
#include "quality/report.hpp"

namespace {

using porta::quality::QualityReport;

struct Options {
  std::string data;
  std::string backend = "cpu";
  std::string device;
  int threads = 0;
  std::string json;
  int max_disparity = 64;
  bool oxford = true;
  bool middlebury = true;
};

void usage(std::ostream& out) {
  out << "usage: porta_quality [--data DIR] [--backend NAME] [--device D] [--threads N] [--json FILE]\n"
         "                     [--max-disparity PX] [--only oxford|middlebury]\n"
         "  --data DIR          the shared data folder (default: $PORTA_DATA_DIR, else "
      << porta::quality::default_data_dir().string()
      << ")\n"
         "  --backend NAME      cpu (default), cuda, vulkan or opencl\n"
         "  --device D          device index or name substring for the backend\n"
         "  --threads N         cpu backend worker threads (0 = all)\n"
         "  --json FILE         also write the numbers as JSON\n"
         "  --max-disparity PX  Middlebury stereo search range 0..PX (default 64)\n"
         "  --only SUITE        run only the oxford or the middlebury suite\n";
}

// Parses the command line; exits 2 with a message on a bad argument.
Options parse(int argc, char** argv) {
  Options o;
  auto value = [&](int& i) -> std::string {
    if (i + 1 >= argc) {
      std::cerr << "porta_quality: " << argv[i] << " needs a value\n";
      usage(std::cerr);
      std::exit(2);
    }
    return argv[++i];
  };
  auto integer = [&](int& i) {
    const std::string name = argv[i];
    const std::string text = value(i);
    try {
      return std::stoi(text);
    } catch (const std::exception&) {
      std::cerr << "porta_quality: " << name << " expects an integer, got '" << text << "'\n";
      std::exit(2);
    }
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--data") {
      o.data = value(i);
    } else if (a == "--backend") {
      o.backend = value(i);
    } else if (a == "--device") {
      o.device = value(i);
    } else if (a == "--threads") {
      o.threads = integer(i);
    } else if (a == "--json") {
      o.json = value(i);
    } else if (a == "--max-disparity") {
      o.max_disparity = integer(i);
    } else if (a == "--only") {
      const std::string suite = value(i);
      if (suite != "oxford" && suite != "middlebury") {
        std::cerr << "porta_quality: --only takes oxford or middlebury, got '" << suite << "'\n";
        std::exit(2);
      }
      o.oxford = suite == "oxford";
      o.middlebury = suite == "middlebury";
    } else if (a == "-h" || a == "--help") {
      usage(std::cout);
      std::exit(0);
    } else {
      std::cerr << "porta_quality: unknown argument '" << a << "'\n";
      usage(std::cerr);
      std::exit(2);
    }
  }
  return o;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void run_oxford(porta::Backend& backend, const std::filesystem::path& data, QualityReport& report) {
  porta::quality::OxfordEvaluator evaluator(backend, report.settings, report.oxford_params);
  for (const auto& set : porta::quality::oxford_sets()) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto first = evaluator.features(porta::quality::load_oxford_image(data, set, 1));
    for (int n = 2; n <= 6; ++n) {
      const auto second = evaluator.features(porta::quality::load_oxford_image(data, set, n));
      report.pairs.push_back(
          evaluator.compare(set, n, first, second, porta::quality::load_oxford_homography(data, set, n)));
      const auto& p = report.pairs.back();
      std::fprintf(stderr,
                   "oxford %-7s 1-%d: repeatability ours %.3f classic %.3f cv-fast %.3f cv-orb %.3f, "
                   "matching ours %.3f cv-orb %.3f\n",
                   set.c_str(), n, p.repeatability[0].value, p.repeatability[1].value,
                   p.repeatability[2].value, p.repeatability[3].value, p.ours_matching.score,
                   p.opencv_matching.score);
    }
    std::fprintf(stderr, "oxford %-7s done in %.1f s\n", set.c_str(), seconds_since(t0));
  }
}

void run_middlebury(porta::Backend& backend, const std::filesystem::path& data, QualityReport& report) {
  for (const auto& scene : porta::quality::middlebury_scenes()) {
    const auto t0 = std::chrono::steady_clock::now();
    report.scenes.push_back(
        porta::quality::evaluate_stereo_scene(backend, report.stereo_settings, data, scene));
    const auto& a = report.scenes.back().accuracy;
    std::fprintf(stderr,
                 "middlebury %-8s: %d matches of %d left keypoints, within 1 px %.3f, 0.5 px %.3f (%.1f s)\n",
                 scene.c_str(), a.matches, a.left_keypoints, a.fraction_within_1px, a.fraction_within_half_px,
                 seconds_since(t0));
  }
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  const std::filesystem::path data = porta::quality::resolve_data_dir(options.data);
  std::vector<std::string> missing;
  if (options.oxford && !std::filesystem::is_directory(data / "oxford-affine"))
    missing.push_back("oxford-affine");
  if (options.middlebury && !std::filesystem::is_directory(data / "middlebury"))
    missing.push_back("middlebury");
  if (!missing.empty()) {
    std::cerr << "porta_quality: the real test data is not there: " << data.string() << " lacks";
    for (const auto& m : missing) std::cerr << " " << m << "/";
    std::cerr << ".\nPass the folder of the shared data with --data DIR or set PORTA_DATA_DIR "
                 "(it is ../shared/data beside the repository on CI).\n";
    return 1;
  }

  try {
    porta::BackendOptions backend_options;
    backend_options.device = options.device;
    backend_options.threads = options.threads;
    auto backend = porta::BackendRegistry::instance().create(options.backend, backend_options);

    QualityReport report;
    report.backend = backend->name() + ": " + backend->device_name();
    report.data_dir = data.string();
    report.settings = porta::quality::with_max_arc(porta::FrontendSettings{}, 13);
    report.stereo_settings = porta::quality::middlebury_settings(report.settings, options.max_disparity);
    report.stereo_settings.validate();

    const auto t0 = std::chrono::steady_clock::now();
    if (options.oxford) run_oxford(*backend, data, report);
    if (options.middlebury) run_middlebury(*backend, data, report);
    report.seconds = seconds_since(t0);

    porta::quality::write_markdown(std::cout, report);
    if (!options.json.empty()) {
      std::ofstream json(options.json);
      if (!json) {
        std::cerr << "porta_quality: cannot write " << options.json << "\n";
        return 1;
      }
      porta::quality::write_json(json, report);
    }
  } catch (const std::exception& e) {
    std::cerr << "porta_quality: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
