#include "render_options.hpp"

#include <functional>
#include <map>
#include <sstream>

#include "cli_args.hpp"
#include "commands.hpp"

namespace porta::app {

namespace {

using slam::render::RenderOptions;

std::size_t parse_count(const std::string& option, const std::string& text, int min) {
  const int v = parse_int(option, text);
  if (v < min) throw CliError("option " + option + " expects an integer >= " + std::to_string(min) + ", got " + text);
  return static_cast<std::size_t>(v);
}

using Apply = std::function<void(RenderOptions&, const std::string& option, const std::string& value)>;

const std::map<std::string, Apply>& value_options() {
  static const std::map<std::string, Apply> options = {
      {"--trajectory", [](auto& o, auto&, auto& v) { o.trajectory_path = v; }},
      {"--format", [](auto& o, auto& n, auto& v) {
         if (v == "auto") return o.format.reset();
         const auto f = slam::parse_trajectory_format(v);
         if (!f) throw CliError("option " + n + " expects kitti, tum, euroc or auto, got '" + v + "'");
         o.format = *f;
       }},
      {"--times", [](auto& o, auto&, auto& v) { o.kitti_times_path = v; }},
      {"--path", [](auto& o, auto& n, auto& v) {
         const auto p = slam::render::parse_builtin_path(v);
         if (!p) throw CliError("option " + n + " expects street-loop or room-orbit, got '" + v + "'");
         o.builtin = *p;
       }},
      {"--pose-is", [](auto& o, auto& n, auto& v) {
         if (v != "camera" && v != "body") throw CliError("option " + n + " expects camera or body, got '" + v + "'");
         o.poses_are_body = v == "body";
       }},
      {"--up", [](auto& o, auto& n, auto& v) {
         const auto a = slam::render::parse_axis(v);
         if (!a) throw CliError("option " + n + " expects x, -x, y, -y, z or -z, got '" + v + "'");
         o.up = *a;
       }},
      {"--world", [](auto& o, auto& n, auto& v) {
         if (v == "auto") o.world = slam::render::WorldKind::automatic;
         else if (v == "street") o.world = slam::render::WorldKind::street;
         else if (v == "room") o.world = slam::render::WorldKind::room;
         else throw CliError("option " + n + " expects street, room or auto, got '" + v + "'");
       }},
      {"--layout", [](auto& o, auto& n, auto& v) {
         if (v == "kitti") o.layout = slam::render::Layout::kitti;
         else if (v == "euroc") o.layout = slam::render::Layout::euroc;
         else throw CliError("option " + n + " expects kitti or euroc, got '" + v + "'");
       }},
      {"--out", [](auto& o, auto&, auto& v) { o.out_dir = v; }},
      {"--size", [](auto& o, auto& n, auto& v) {
         const auto x = v.find('x');
         if (x == std::string::npos) throw CliError("option " + n + " expects WIDTHxHEIGHT, e.g. 1242x375, got '" + v + "'");
         const int w = parse_int(n, v.substr(0, x)), h = parse_int(n, v.substr(x + 1));
         if (w < 16 || h < 16 || w > 8192 || h > 8192)
           throw CliError("option " + n + " expects a size in [16, 8192] x [16, 8192], got '" + v + "'");
         o.width = w;
         o.height = h;
       }},
      {"--fx", [](auto& o, auto& n, auto& v) { o.fx = parse_double(n, v); }},
      {"--fy", [](auto& o, auto& n, auto& v) { o.fy = parse_double(n, v); }},
      {"--cx", [](auto& o, auto& n, auto& v) { o.cx = parse_double(n, v); }},
      {"--cy", [](auto& o, auto& n, auto& v) { o.cy = parse_double(n, v); }},
      {"--baseline", [](auto& o, auto& n, auto& v) { o.baseline_m = parse_double(n, v); }},
      {"--stride", [](auto& o, auto& n, auto& v) { o.stride = static_cast<int>(parse_count(n, v, 1)); }},
      {"--fps", [](auto& o, auto& n, auto& v) { o.fps = parse_double(n, v); }},
      {"--first", [](auto& o, auto& n, auto& v) { o.first = parse_count(n, v, 0); }},
      {"--count", [](auto& o, auto& n, auto& v) { o.count = parse_count(n, v, 1); }},
      {"--seed", [](auto& o, auto& n, auto& v) { o.seed = parse_count(n, v, 0); }},
      {"--supersample", [](auto& o, auto& n, auto& v) { o.supersample = parse_int(n, v); }},
      {"--noise", [](auto& o, auto& n, auto& v) { o.noise_sigma = parse_double(n, v); }},
      {"--exposure", [](auto& o, auto& n, auto& v) { o.exposure_amplitude = parse_double(n, v); }},
      {"--motion-blur", [](auto& o, auto& n, auto& v) { o.motion_blur = parse_double(n, v); }},
      {"--blur-samples", [](auto& o, auto& n, auto& v) { o.blur_samples = parse_int(n, v); }},
      {"--threads", [](auto& o, auto& n, auto& v) { o.threads = parse_threads(n, v); }},
  };
  return options;
}

}  // namespace

RenderCommandOptions parse_render_options(const std::vector<std::string>& args) {
  RenderCommandOptions options;
  ArgumentCursor cursor(args);
  while (!cursor.done()) {
    const std::string arg = cursor.take();
    if (arg == "--help" || arg == "-h") {
      options.help = true;
      continue;
    }
    if (arg == "--quiet") {
      if (cursor.has_inline_value()) throw CliError("option --quiet takes no value");
      options.quiet = true;
      continue;
    }
    const auto it = value_options().find(arg);
    if (it != value_options().end()) {
      it->second(options.render, arg, cursor.value(arg));
      continue;
    }
    if (arg.size() > 1 && arg[0] == '-') throw CliError("unknown option '" + arg + "' (see `portaslam render --help`)");
    if (!options.render.trajectory_path.empty())
      throw CliError("more than one trajectory: '" + options.render.trajectory_path + "' and '" + arg + "'");
    options.render.trajectory_path = arg;
  }
  if (!options.help && options.render.out_dir.empty())
    throw CliError("option --out DIR is required: the folder to write the sequence to");
  return options;
}

std::string render_usage() {
  std::ostringstream u;
  u << "Usage: portaslam render [TRAJECTORY] --out DIR [OPTIONS]\n"
       "\n"
       "Renders a rectified stereo sequence of a static, textured, procedurally generated world (a street\n"
       "for car paths, a room for drone paths) along a camera path, with exact ground truth, in the KITTI\n"
       "odometry or the EuRoC ASL layout. With no TRAJECTORY: 200 frames of the built-in street loop.\n"
       "The same arguments always give the same bytes, whatever --threads.\n"
       "\n"
       "Path:\n"
       "  TRAJECTORY, --trajectory FILE   poses in KITTI (12 or 13 numbers a line), TUM or EuRoC CSV format\n"
       "  --format F           kitti, tum, euroc or auto (default auto: detected from the first line)\n"
       "  --times FILE         KITTI times.txt for a KITTI pose file (default: 10 Hz)\n"
       "  --path NAME          built-in path: street-loop (a closed ~490 m drive, 612 frames at 10 Hz)\n"
       "                       or room-orbit (a 60 s drone flight in a room, 20 Hz)\n"
       "  --pose-is WHAT       camera or body (default: camera for KITTI, body for TUM and EuRoC; body\n"
       "                       poses get EuRoC cam0's body-to-camera transform T_BS)\n"
       "  --up AXIS            the input world's up axis: x, -x, y, -y, z, -z (default -y for KITTI, else z)\n"
       "World and output:\n"
       "  --world W            street, room or auto (default auto: street when the path spans > 30 m)\n"
       "  --layout L           kitti or euroc (default kitti for a street, euroc for a room)\n"
       "  --out DIR            output folder (created; required)\n"
       "  --seed N             world, texture and noise seed (default 1)\n"
       "Camera (defaults: KITTI 1242x375 fx=fy=718.856 cx=607.19 cy=185.22 baseline 0.537 m for a street;\n"
       "EuRoC 752x480 fx=fy=458 cx=376 cy=240 baseline 0.11 m for a room):\n"
       "  --size WxH           image size; without --fx etc. the default intrinsics scale with the width\n"
       "  --fx F --fy F --cx C --cy C   intrinsics in pixels\n"
       "  --baseline B         stereo baseline in metres, (0, 10]\n"
       "Frames:\n"
       "  --fps F              resample the path at F frames/s (linear + slerp interpolation)\n"
       "  --stride N           take every Nth pose (after --fps; default 1)\n"
       "  --first N            first frame to render, counted after sampling (default 0)\n"
       "  --count N            frames to render (default: to the end)\n"
       "Images:\n"
       "  --supersample K      K x K samples per pixel, [1, 4] (default 2)\n"
       "  --noise SIGMA        Gaussian noise in grey levels, [0, 64] (default 1)\n"
       "  --exposure A         smooth gain/offset changes over time, gain within 1 +- A, [0, 0.9] (default 0)\n"
       "  --motion-blur S      shutter as a fraction of the frame interval, [0, 1] (default 0 = off)\n"
       "  --blur-samples N     sub-frame renders per image when blurring, [2, 64] (default 5)\n"
       "Run:\n"
       "  --threads N          frames rendered in parallel, 0 = all hardware threads (default 0)\n"
       "  --quiet              no progress on stderr\n"
       "\n"
       "Exit status: 0 success; 1 bad option, value, trajectory, frame range or output folder.\n";
  return u.str();
}

}  // namespace porta::app
