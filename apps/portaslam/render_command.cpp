// `portaslam render`: renders a stereo sequence with exact ground truth (slam/render, DESIGN.md §7).
#include <cstdio>
#include <iostream>

#include "cli_args.hpp"
#include "commands.hpp"
#include "output_paths.hpp"
#include "render_options.hpp"

namespace porta::app {

namespace {

const char* layout_name(slam::render::Layout l) { return l == slam::render::Layout::kitti ? "KITTI" : "EuRoC"; }

int run(const RenderCommandOptions& options) {
  using namespace slam::render;
  check_output_folder("--out", options.render.out_dir);
  const SequencePlan plan = plan_sequence(options.render);
  const slam::StereoCamera& c = plan.camera;
  std::cout << "source:  " << plan.source << "\n"
            << "world:   " << plan.world->description << "\n"
            << "camera:  " << c.describe() << ", supersample " << plan.options.supersample << "x" << plan.options.supersample
            << "\n"
            << "frames:  " << plan.frames.size() << " (from " << plan.options.first << ", " << plan.rate_hz << " Hz)\n"
            << "output:  " << plan.options.out_dir << " (" << layout_name(plan.layout) << " layout)\n"
            << std::flush;
  const auto progress = [&](std::size_t done, std::size_t total, double seconds) {
    if (options.quiet) return;
    const double rate = seconds > 0 ? done / seconds : 0.0;
    const double eta = rate > 0 ? (total - done) / rate : 0.0;
    std::fprintf(stderr, "render: frame %zu/%zu, %.1f frames/s, ETA %.0f s\n", done, total, rate, eta);
  };
  const WriteReport report = write_sequence(plan, progress);
  std::cout << "rendered " << report.frames << " stereo frames in " << report.seconds << " s ("
            << (report.seconds > 0 ? report.frames / report.seconds : 0.0) << " frames/s, " << plan.options.threads
            << " threads)\n";
  return 0;
}

}  // namespace

int render_command(const std::vector<std::string>& args) {
  const char* const who = "portaslam render: ";
  try {
    const RenderCommandOptions options = parse_render_options(args);
    if (options.help) {
      std::cout << render_usage();
      return 0;
    }
    return run(options);
  } catch (const CliError& e) {
    std::cerr << who << e.what() << '\n';
  } catch (const slam::render::RenderError& e) {
    std::cerr << who << e.what() << '\n';
  } catch (const slam::TrajectoryError& e) {
    std::cerr << who << "bad trajectory: " << e.what() << '\n';
  } catch (const std::exception& e) {
    std::cerr << who << "failed: " << e.what() << '\n';
  }
  return 1;
}

}  // namespace porta::app
