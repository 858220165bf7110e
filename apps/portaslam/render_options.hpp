// Command-line options of `portaslam render` (render_command.cpp).
#pragma once

#include <string>
#include <vector>

#include "porta/slam/render/sequence.hpp"

namespace porta::app {

struct RenderCommandOptions {
  slam::render::RenderOptions render;
  bool help = false;
  bool quiet = false;
};

/// Parses `portaslam render` arguments; throws CliError naming the option and the allowed values.
RenderCommandOptions parse_render_options(const std::vector<std::string>& args);

}  // namespace porta::app
