// `portaslam demo`: renders a short stereo sequence along the built-in street loop (slam/render)
// and runs SLAM on it (slam_run.cpp), so that a new user sees the whole system work, and how
// accurately, without downloading anything.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "cli_args.hpp"
#include "commands.hpp"
#include "output_paths.hpp"
#include "porta/registry.hpp"
#include "porta/slam/render/sequence.hpp"
#include "porta/slam/settings_file.hpp"
#include "slam_run.hpp"

namespace porta::app {

std::string demo_usage() {
  return "Usage: portaslam demo [OPTIONS]\n"
         "\n"
         "Renders a stereo sequence of a textured street along the built-in closed loop (KITTI layout,\n"
         "1242x375, exact ground truth) into DIR/sequence, then runs stereo SLAM on it and prints the\n"
         "per-stage timing and the ATE against the rendered ground truth.\n"
         "\n"
         "Options:\n"
         "  --dir DIR           working folder (default portaslam-demo): DIR/sequence, DIR/run\n"
         "  --render-frames N   frames to render (default 150)\n"
         "  --seed N            world seed (default 1)\n" +
         slam_run_options_usage() +
         "\n"
         "Example:\n"
         "  portaslam demo --render-frames 100 --mode deterministic\n";
}

int demo_command(const std::vector<std::string>& args) {
  const char* const who = "portaslam demo: ";
  try {
    std::string dir = "portaslam-demo";
    int frames = 150;
    int seed = 1;
    SlamRunOptions run;
    bool out_given = false;
    ArgumentCursor cursor(args);
    while (!cursor.done()) {
      const std::string option = cursor.take();
      if (option == "--help" || option == "-h") {
        std::cout << demo_usage();
        return 0;
      }
      if (option == "--dir") {
        dir = cursor.value(option);
      } else if (option == "--render-frames") {
        frames = parse_int(option, cursor.value(option));
        if (frames < 3) throw CliError("--render-frames must be >= 3");
      } else if (option == "--seed") {
        seed = parse_int(option, cursor.value(option));
        if (seed < 0) throw CliError("--seed must be >= 0");
      } else if (parse_slam_run_option(option, cursor, run)) {
        if (option == "--out") out_given = true;
      } else {
        throw CliError("unknown option '" + option + "' (see portaslam demo --help)");
      }
    }
    const std::filesystem::path folder = prepare_output_folder("--dir", dir);
    slam::render::RenderOptions render;
    render.builtin = slam::render::BuiltinPath::street_loop;
    render.out_dir = (folder / "sequence").string();
    render.count = static_cast<std::size_t>(frames);
    render.seed = static_cast<std::uint64_t>(seed);
    render.layout = slam::render::Layout::kitti;
    std::printf("rendering %d stereo frames of the built-in street loop into %s ...\n", frames,
                render.out_dir.c_str());
    std::fflush(stdout);
    const slam::render::SequencePlan plan = slam::render::plan_sequence(render);
    const slam::render::WriteReport report = slam::render::write_sequence(plan);
    std::printf("rendered %zu frames in %.1f s (%.1f stereo frames/s)\n\n", report.frames, report.seconds,
                report.frames / std::max(report.seconds, 1e-9));
    run.kind = slam::DatasetKind::kitti;
    run.path = render.out_dir;
    if (!out_given) run.out = (folder / "run").string();
    const SlamRunSummary summary = run_slam(run);
    std::printf("\ndemo: %zu of %zu frames tracked%s\n", summary.tracked, summary.frames,
                summary.lost == 0 ? ", tracking never lost" : "");
    return summary.lost == 0 ? 0 : 1;
  } catch (const CliError& e) {
    std::cerr << who << e.what() << '\n';
  } catch (const BackendError& e) {
    std::cerr << who << e.what() << "\n(`portaslam backends` lists what this binary has and can use)\n";
  } catch (const std::exception& e) {
    std::cerr << who << "failed: " << e.what() << '\n';
  }
  return 1;
}

}  // namespace porta::app
