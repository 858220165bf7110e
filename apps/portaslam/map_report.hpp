// The map outputs of `portaslam run`: the PLY export of the map (--export-map FILE) and the top-view
// picture (<out>/map_top.png, every run), with their lines of the summary and of summary.json.
#pragma once

#include <string>

#include "porta/slam/evaluation.hpp"
#include "porta/slam/map_export.hpp"
#include "porta/slam/pose.hpp"

namespace porta::app {

struct MapOutputOptions {
  std::string export_path;  ///< empty: no PLY
  slam::MapColouring colouring = slam::MapColouring::height;
  std::string top_view_path;
  std::string title;  ///< the picture's caption
};

struct MapReport {
  slam::MapExportStats exported;  ///< zero when nothing was exported
  std::string json;               ///< the "map_export" and "top_view" members of summary.json
};

/// Writes the PLY (when asked) and the top view, prints a line for each, and returns the counts.
/// `evaluation` (may be null): its association and SE(3) alignment bring the ground truth into the
/// map's frame for the picture. Throws CliError when a file cannot be written.
MapReport write_map_outputs(const slam::MapCloud& cloud, const slam::Trajectory& estimate,
                            const slam::Trajectory* ground_truth, const slam::EvaluationResult* evaluation,
                            const MapOutputOptions& options);

/// The usage lines of --export-map and --export-map-colour (shared by run and demo).
std::string map_output_options_usage();

}  // namespace porta::app
