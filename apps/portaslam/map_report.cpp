#include "map_report.hpp"

#include <algorithm>
#include <cstdio>
#include <vector>

#include "cli_args.hpp"
#include "imageio/png_file.hpp"
#include "porta/json_text.hpp"
#include "porta/slam/atomic_file.hpp"
#include "porta/slam/top_view.hpp"

namespace porta::app {

namespace {

/// The ground truth over the frames the estimate covers, moved into the map's frame by the
/// inverse of the evaluation's SE(3) alignment (which maps the estimate onto the ground truth).
std::vector<Eigen::Vector3d> ground_truth_in_map_frame(const slam::Trajectory& ground_truth,
                                                       const slam::EvaluationResult& evaluation) {
  const slam::Association& pairs = evaluation.association;
  if (pairs.gt_index.empty()) return {};
  const auto [lo, hi] = std::minmax_element(pairs.gt_index.begin(), pairs.gt_index.end());
  const slam::Alignment& a = evaluation.alignment;
  std::vector<Eigen::Vector3d> positions;
  for (std::size_t k = *lo; k <= *hi && k < ground_truth.size(); ++k) {
    const Eigen::Vector3d p = ground_truth.poses[k].pose.translation();
    positions.push_back(a.rotation.transpose() * (p - a.translation) / a.scale);
  }
  return positions;
}

}  // namespace

MapReport write_map_outputs(const slam::MapCloud& cloud, const slam::Trajectory& estimate,
                            const slam::Trajectory* ground_truth, const slam::EvaluationResult* evaluation,
                            const MapOutputOptions& options) {
  MapReport report;
  std::string export_json = "null";
  if (!options.export_path.empty()) {
    try {
      report.exported = slam::write_map_ply(options.export_path, cloud, options.colouring);
    } catch (const slam::AtomicWriteError& e) {
      throw CliError(std::string("--export-map: ") + e.what());
    }
    const slam::MapExportStats& s = report.exported;
    std::printf(
        "map export  %s: %zu vertices (%zu map points + %zu keyframe centres), coloured by %s, %zu bytes\n",
        options.export_path.c_str(), s.vertices(), s.map_points, s.keyframe_centres,
        slam::to_string(options.colouring), s.file_bytes);
    if (s.skipped_non_finite > 0) {
      std::printf(
          "WARNING: %zu map points or keyframes with a non-finite position were left out of the export\n",
          s.skipped_non_finite);
    }
    export_json = "{\"path\": " + json_string(options.export_path) +
                  ", \"vertices\": " + std::to_string(s.vertices()) +
                  ", \"map_points\": " + std::to_string(s.map_points) +
                  ", \"keyframe_centres\": " + std::to_string(s.keyframe_centres) +
                  ", \"skipped_non_finite\": " + std::to_string(s.skipped_non_finite) + ", \"colour\": \"" +
                  slam::to_string(options.colouring) + "\", \"bytes\": " + std::to_string(s.file_bytes) + "}";
  }

  slam::TopViewInput view;
  view.title = options.title;
  view.map_points.reserve(cloud.points.size());
  for (const slam::MapCloud::Point& p : cloud.points) view.map_points.push_back(p.position);
  for (const slam::StampedPose& p : estimate.poses) view.estimate.push_back(p.pose.translation());
  if (ground_truth != nullptr && evaluation != nullptr) {
    view.ground_truth = ground_truth_in_map_frame(*ground_truth, *evaluation);
    view.ground_truth_label = "ground truth (SE(3)-aligned)";
  }
  const slam::RgbImage picture = slam::draw_top_view(view);
  try {
    io::write_png_rgb(options.top_view_path, picture.width, picture.height, picture.rgb.data(),
                      static_cast<std::size_t>(picture.width) * 3);
  } catch (const io::PngError& e) {
    throw CliError("cannot write the top view '" + options.top_view_path + "': " + e.what());
  }
  std::printf("top view    %s (%dx%d: map points, estimate%s)\n", options.top_view_path.c_str(),
              picture.width, picture.height, view.ground_truth.empty() ? "" : ", ground truth");
  report.json = "\"map_export\": " + export_json + ",\n  \"top_view\": " + json_string(options.top_view_path);
  return report;
}

std::string map_output_options_usage() {
  return "  --export-map FILE   write the map as a binary PLY point cloud at the end (map points, then the\n"
         "                      keyframes' camera centres in magenta; MeshLab, CloudCompare, Open3D)\n"
         "  --export-map-colour C\n"
         "                      the PLY's point colours: height (default; up = -y) or keyframe\n";
}

}  // namespace porta::app
