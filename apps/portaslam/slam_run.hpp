// Running the SLAM pipeline over a dataset, shared by `portaslam run` and `portaslam demo`:
// progress on stderr, the trajectory files, per-stage statistics and, with ground truth, the ATE.
#pragma once

#include <cstddef>
#include <string>

#include "porta/slam/dataset.hpp"
#include "porta/slam/map_export.hpp"
#include "porta/slam/slam_settings.hpp"

namespace porta::app {

struct SlamRunOptions {
  slam::DatasetKind kind = slam::DatasetKind::kitti;
  std::string path;
  slam::DatasetOptions dataset;   ///< settings file and ground-truth override
  std::string backend = "cpu";
  std::string device;
  int threads = 0;                ///< cpu backend worker threads, 0 = all
  int mapping_threads = 0;        ///< SlamSettings::mapping_threads (0: by the machine)
  int ba_every = 4;               ///< SlamSettings::bundle_adjustment_every
  bool keyframes_while_mapping = true;  ///< SlamSettings::keyframes_while_mapping
  bool queued_follow_ba = true;         ///< SlamSettings::queued_keyframes_follow_ba
  bool tracking_releases_map_lock = false;  ///< SlamSettings::tracking_releases_map_lock
  double ba_tolerance = 1e-3;     ///< SlamSettings::realtime_bundle_adjustment_tolerance
  int ba_steps = 1;               ///< SlamSettings::realtime_bundle_adjustment_steps
  int keyframe_queue = 2;         ///< SlamSettings::keyframe_queue_limit
  int keyframe_gap = 0;           ///< SlamSettings::min_frames_between_keyframes
  bool projection_on_backend = true;  ///< SlamSettings::projection_on_backend
  bool pinned_input = true;       ///< pairs read into the System's input images (else copied on submit)
  slam::RunMode mode = slam::RunMode::realtime;
  std::string out = "portaslam-run";
  std::size_t first = 0;
  std::size_t count = 0;          ///< 0 = to the end
  int levels = 0;                 ///< 0 = the settings file's or the default (8)
  int cell = 0;                   ///< culling cell size, 0 = slam::default_cell_size of the image
  std::string json;               ///< summary JSON path; empty = <out>/summary.json
  bool quiet = false;             ///< no progress lines
  /// Playback speed relative to the recorded frame times: each pair is handed to SLAM no earlier
  /// than (its time - the first time) / rate after the start, as a camera at rate x its frame
  /// rate would deliver it. 0 = as fast as possible.
  double rate = 0.0;
  bool loop_closing = true;       ///< --no-loop-closing: odometry with local BA only
  bool global_ba = true;          ///< --no-global-ba: no global bundle adjustment after a loop
  std::string save_map;           ///< --save-map FILE: the map at the end of the run
  std::string load_map;           ///< --load-map FILE: continue on a saved map
  bool localization = false;      ///< --localization: track on the loaded map, add nothing
  std::string export_map;         ///< --export-map FILE: the map as a PLY point cloud at the end
  slam::MapColouring export_colouring = slam::MapColouring::height;  ///< --export-map-colour
};

/// What a run measured, for callers that check it (demo, tests).
struct SlamRunSummary {
  std::size_t frames = 0, tracked = 0, lost = 0, keyframes = 0, map_points = 0;
  bool has_ate = false;
  double ate_rmse_m = 0.0, path_length_m = 0.0;
  double median_frame_ms = 0.0;
  std::size_t late_frames = 0;    ///< with a rate: frames that took longer than their interval
  std::size_t loops_detected = 0, loops_closed = 0, relocalisations = 0, global_ba_runs = 0;
  double map_load_ms = 0.0;
  std::size_t exported_vertices = 0;  ///< --export-map: vertices in the PLY (map points + keyframe centres)
  /// From the first frame handed over to the last one processed (the frames' loop, not the
  /// start-up or the final writes): wall time, and the process's CPU time over it (every thread:
  /// reader, tracking, mapping, loop closing, the cpu backend's workers).
  double wall_s = 0.0, cpu_s = 0.0;
  double peak_resident_mib = 0.0;
  /// Every kMemorySampleFrames frames and at the end: resident memory and the map's size.
  struct MemorySample {
    std::size_t frame = 0;
    double resident_mib = 0.0;
    std::size_t keyframes = 0, map_points = 0;
  };
  static constexpr std::size_t kMemorySampleFrames = 500;
  std::vector<MemorySample> memory;
};

/// Runs and reports. Throws CliError / DatasetError / SettingsFileError / BackendError with a
/// message for the user.
SlamRunSummary run_slam(const SlamRunOptions& options);

/// Usage of the options run_slam understands (shared by run and demo).
std::string slam_run_options_usage();
/// Parses one option of SlamRunOptions; false when `option` is not one of them.
class ArgumentCursor;
bool parse_slam_run_option(const std::string& option, ArgumentCursor& cursor, SlamRunOptions& options);

}  // namespace porta::app
