// portaslam: the command-line entry point. Dispatches to one subcommand per file; prints usage for
// --help/help (stdout, exit 0) and for a missing or unknown command (stderr, exit 2).
#include <iostream>
#include <string>
#include <vector>

#include "bench_options.hpp"
#include "commands.hpp"

namespace {

const char* const kUsage =
    "Usage: portaslam COMMAND [OPTIONS]\n"
    "\n"
    "PortaSLAM: a stereo visual SLAM engine whose feature frontend runs on interchangeable\n"
    "compute backends (cpu, cuda, vulkan, opencl) with bit-identical results.\n"
    "\n"
    "Commands:\n"
    "  backends   list every compute backend: built into this binary? usable on this machine?\n"
    "  bench      time the frontend over resolutions x pyramid levels x modes per backend,\n"
    "             with OpenCV's ORB as a peer; prints a table, --json FILE for every number\n"
    "  features   detect ORB features (and stereo matches) in an image or a rectified stereo pair,\n"
    "             print counts and per-stage times, and write an annotated PNG;\n"
    "             with no image it runs on a built-in synthetic stereo pair\n"
  #if PORTA_APPS_HAVE_RENDER
  "  render     render a rectified stereo sequence of a textured street or room along a real or\n"
  "             built-in camera path, with exact ground truth (KITTI or EuRoC layout)\n"
#endif
#if PORTA_APPS_HAVE_EVAL
  "  eval       evaluate an estimated trajectory against ground truth: ATE, RPE, KITTI\n"
  "             relative errors; JSON report and PNG plots\n"
#endif
#if PORTA_APPS_HAVE_RUN
  "  run        stereo SLAM over a KITTI, EuRoC or folder dataset: trajectory, per-stage timing, ATE\n"
#endif
#if PORTA_APPS_HAVE_DEMO
  "  demo       render a short stereo sequence along a built-in street loop and run SLAM on it\n"
#endif
#if PORTA_APPS_HAVE_MAP
  "  map        `map info FILE`: describe and check a saved map file; `map export FILE OUT.ply`\n"
#endif
  "  help       show this text (also: portaslam --help); `portaslam help COMMAND` for details\n"
    "\n"
    "Examples:\n"
    "  portaslam backends\n"
    "  portaslam features\n"
    "  portaslam features left.png right.png --backend cpu --out pair.png\n"
    "  portaslam bench --resolutions 640x480 --levels 8 --json bench.json\n"
    "\n"
    "Exit status: 0 success, 1 bad input or a failed run (message on stderr), 2 bad command.\n";

int help(const std::vector<std::string>& args) {
  if (!args.empty() && args[0] == "features") {
    std::cout << porta::app::features_usage();
    return 0;
  }
  if (!args.empty() && args[0] == "bench") {
    std::cout << porta::app::bench_usage();
    return 0;
  }
  if (!args.empty() && args[0] == "backends") {
    std::cout << "Usage: portaslam backends\n\nLists every compute backend PortaSLAM knows: whether this binary "
                 "was built with it,\nwhether a usable device was found, and the device or the reason it is "
                 "unavailable.\n";
    return 0;
  }
#if PORTA_APPS_HAVE_RENDER
  if (!args.empty() && args[0] == "render") {
    std::cout << porta::app::render_usage();
    return 0;
  }
#endif
#if PORTA_APPS_HAVE_RUN
  if (!args.empty() && args[0] == "run") {
    std::cout << porta::app::run_usage();
    return 0;
  }
#endif
#if PORTA_APPS_HAVE_DEMO
  if (!args.empty() && args[0] == "demo") {
    std::cout << porta::app::demo_usage();
    return 0;
  }
#endif
#if PORTA_APPS_HAVE_MAP
  if (!args.empty() && args[0] == "map") {
    std::cout << porta::app::map_usage();
    return 0;
  }
#endif
#if PORTA_APPS_HAVE_EVAL
  if (!args.empty() && args[0] == "eval") {
    std::cout << porta::app::eval_usage();
    return 0;
  }
#endif
  std::cout << kUsage;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> all(argv + 1, argv + argc);
  if (all.empty()) {
    std::cerr << "portaslam: no command given\n\n" << kUsage;
    return 2;
  }
  const std::string& command = all[0];
  const std::vector<std::string> rest(all.begin() + 1, all.end());
  if (command == "--help" || command == "-h" || command == "help") return help(rest);
  if (command == "backends") return porta::app::backends_command(rest);
  if (command == "features") return porta::app::features_command(rest);
  if (command == "bench") return porta::app::bench_command(rest);
#if PORTA_APPS_HAVE_RENDER
  if (command == "render") return porta::app::render_command(rest);
#endif
#if PORTA_APPS_HAVE_EVAL
  if (command == "eval") return porta::app::eval_command(rest);
#endif
#if PORTA_APPS_HAVE_RUN
  if (command == "run") return porta::app::run_command(rest);
#endif
#if PORTA_APPS_HAVE_DEMO
  if (command == "demo") return porta::app::demo_command(rest);
#endif
#if PORTA_APPS_HAVE_MAP
  if (command == "map") return porta::app::map_command(rest);
#endif
  std::cerr << "portaslam: unknown command '" << command << "'\n\n" << kUsage;
  return 2;
}
