// `portaslam map info FILE`: what a saved map file holds (format, camera, pyramid, keyframes, map
// points, graph edges, time span, sections), read and checked as loading would check it
// (porta/slam/map_file.hpp). `portaslam map export FILE OUT.ply`: the map as a PLY point cloud
// (porta/slam/map_export.hpp). A bad file is exit status 1 with the loader's message.
#include <cstdio>
#include <mutex>
#include <iostream>
#include <string>
#include <vector>

#include "cli_args.hpp"
#include "commands.hpp"
#include "output_paths.hpp"
#include "porta/slam/atomic_file.hpp"
#include "porta/slam/map_export.hpp"
#include "porta/slam/map_file.hpp"

namespace porta::app {

namespace {

std::string fixed(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

void print_info(const std::string& path, const slam::MapFileInfo& info) {
  const FrontendSettings& frontend = info.settings.frontend;
  std::cout << "map file      " << path << '\n'
            << "format        version " << info.version << ", " << info.file_size << " bytes\n"
            << "camera        " << info.settings.camera.describe() << '\n'
            << "pyramid       " << frontend.levels << " levels, scale factor "
            << fixed("%.4g", frontend.scale_factor) << '\n'
            << "keyframes     " << info.keyframes;
  if (info.keyframes > 0)
    std::cout << " (ids " << info.first_keyframe_id << " to " << info.last_keyframe_id << ")";
  std::cout << '\n'
            << "map points    " << info.map_points << '\n'
            << "observations  " << info.observations << '\n'
            << "covisibility  " << info.covisibility_edges << " edges\n"
            << "loop edges    " << info.loop_edges << '\n';
  if (info.keyframes > 0) {
    std::cout << "time span     " << fixed("%.3f", info.first_time_s) << " to "
              << fixed("%.3f", info.last_time_s) << " s ("
              << fixed("%.3f", info.last_time_s - info.first_time_s) << " s)\n";
  } else {
    std::cout << "time span     none (no keyframes)\n";
  }
  std::cout << "place db      " << info.place_database_bytes << " bytes\n"
            << "sections      tag   offset          bytes\n";
  for (const slam::MapFileSection& s : info.sections) {
    char line[96];
    std::snprintf(line, sizeof line, "              %-4s  %-14llu  %llu\n", s.tag.c_str(),
                  static_cast<unsigned long long>(s.offset), static_cast<unsigned long long>(s.size));
    std::cout << line;
  }
}

int usage_error(const std::string& message) {
  std::cerr << message << "\n\n" << map_usage();
  return 2;
}

/// `map export FILE OUT.ply [--colour height|keyframe]`.
int export_command(const std::vector<std::string>& args) {
  std::vector<std::string> files;
  slam::MapColouring colouring = slam::MapColouring::height;
  for (std::size_t i = 1; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") {
      std::cout << map_usage();
      return 0;
    }
    if (args[i] == "--colour" || args[i] == "--color") {
      if (i + 1 == args.size()) {
        return usage_error("portaslam map export: option " + args[i] + " needs a value");
      }
      const auto parsed = slam::parse_map_colouring(args[++i]);
      if (!parsed) {
        return usage_error("portaslam map export: " + args[i - 1] + " must be height or keyframe, got '" +
                           args[i] + "'");
      }
      colouring = *parsed;
    } else if (args[i].starts_with("-")) {
      return usage_error("portaslam map export: unknown option '" + args[i] + "'");
    } else {
      files.push_back(args[i]);
    }
  }
  if (files.size() != 2) {
    return usage_error("portaslam map export: expected a map FILE and an OUT.ply, got " +
                       std::to_string(files.size()) + (files.size() == 1 ? " argument" : " arguments"));
  }
  try {
    check_output_file("OUT.ply", files[1]);
    slam::Map map;
    slam::load_map(files[0], map);
    slam::MapCloud cloud;
    {
      std::lock_guard lock(map.mutex);
      cloud = slam::map_cloud(map);
    }
    const slam::MapExportStats s = slam::write_map_ply(files[1], cloud, colouring);
    std::cout << "map export  " << files[1] << ": " << s.vertices() << " vertices (" << s.map_points
              << " map points + " << s.keyframe_centres << " keyframe centres), coloured by "
              << slam::to_string(colouring) << ", " << s.file_bytes << " bytes\n";
    return 0;
  } catch (const slam::MapFileError& e) {
    std::cerr << "portaslam map export: " << e.what() << '\n';
  } catch (const CliError& e) {
    std::cerr << "portaslam map export: " << e.what() << '\n';
  } catch (const slam::AtomicWriteError& e) {
    std::cerr << "portaslam map export: " << e.what() << '\n';
  } catch (const std::exception& e) {
    std::cerr << "portaslam map export: failed: " << e.what() << '\n';
  }
  return 1;
}

}  // namespace

std::string map_usage() {
  return "Usage: portaslam map info FILE\n"
         "       portaslam map export FILE OUT.ply [--colour height|keyframe]\n"
         "\n"
         "Reads a map file saved by PortaSLAM (porta::slam::save_map) and prints its format version and\n"
         "size, the camera, the pyramid levels and scale factor, the numbers of keyframes, map points,\n"
         "observations, covisibility and loop edges, the keyframes' time span, and every section with its\n"
         "offset and size. The file is checked as loading it would check it: magic, version, sizes,\n"
         "checksums and the links between keyframes and map points.\n"
         "\n"
         "\n"
         "export writes the map's points and keyframe camera centres as a binary PLY point cloud (as\n"
         "portaslam run --export-map does): points coloured by height (default; up = -y) or by keyframe,\n"
         "camera centres in magenta.\n"
         "\n"
         "Exit status: 0 a good map file, 1 a missing, unreadable or corrupt file (the message says which\n"
         "and where) or an output that cannot be written, 2 a usage error.\n";
}

int map_command(const std::vector<std::string>& args) {
  if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
    std::cout << map_usage();
    return 0;
  }
  if (args.empty()) {
    std::cerr << "portaslam map: no subcommand given (expected: info FILE or export FILE OUT.ply)\n\n"
              << map_usage();
    return 2;
  }
  if (args[0] == "export") return export_command(args);
  if (args[0] != "info") {
    std::cerr << "portaslam map: unknown subcommand '" << args[0]
              << "' (expected: info FILE or export FILE OUT.ply)\n\n"
              << map_usage();
    return 2;
  }
  if (args.size() == 2 && (args[1] == "--help" || args[1] == "-h")) {
    std::cout << map_usage();
    return 0;
  }
  if (args.size() != 2 || args[1].starts_with("-")) {
    std::cerr << "portaslam map info: expected one FILE, got "
              << (args.size() == 1 ? std::string("none") : std::to_string(args.size() - 1) + " arguments")
              << "\n\n"
              << map_usage();
    return 2;
  }
  try {
    print_info(args[1], slam::read_map_info(args[1]));
    return 0;
  } catch (const slam::MapFileError& e) {
    std::cerr << "portaslam map info: " << e.what() << '\n';
  } catch (const std::exception& e) {
    std::cerr << "portaslam map info: failed: " << e.what() << '\n';
  }
  return 1;
}

}  // namespace porta::app
