#include "slam_run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <map>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "cli_args.hpp"
#include "frame_log.hpp"
#include "loop_report.hpp"
#include "map_report.hpp"
#include "output_paths.hpp"
#include "pair_reader.hpp"
#include "process_memory.hpp"
#include "thread_cpu.hpp"
#include "porta/registry.hpp"
#include "porta/slam/atomic_file.hpp"
#include "porta/slam/evaluation.hpp"
#include "porta/slam/settings_file.hpp"
#include "porta/slam/system.hpp"
#include "porta/slam/trajectory_io.hpp"

namespace porta::app {

namespace {

namespace fs = std::filesystem;

/// The nice values of the mapping and loop-closing threads as fast as possible (frontend_threads).
constexpr int kUnpacedMappingNice = 5;
constexpr int kUnpacedLoopClosingNice = 19;

struct Quantiles {
  double median_ms = 0.0, p95_ms = 0.0, mean_ms = 0.0;
  std::size_t count = 0;
};

Quantiles quantiles(std::vector<std::int64_t> ns) {
  Quantiles q;
  q.count = ns.size();
  if (ns.empty()) return q;
  std::sort(ns.begin(), ns.end());
  auto at = [&](double f) {
    const std::size_t i = std::min(ns.size() - 1, static_cast<std::size_t>(std::floor(f * (ns.size() - 1) + 0.5)));
    return ns[i] / 1e6;
  };
  q.median_ms = at(0.5);
  q.p95_ms = at(0.95);
  double sum = 0.0;
  for (std::int64_t v : ns) sum += v / 1e6;
  q.mean_ms = sum / ns.size();
  return q;
}

slam::SlamSettings make_settings(const SlamRunOptions& options, const slam::StereoDataset& dataset) {
  // Culling cells fit to the image size and the whole disparity range, unless given.
  slam::SlamSettings settings = slam::default_settings(dataset.camera());
  const int fitted_cell = settings.frontend.cell_width;
  if (!options.dataset.settings_path.empty()) {
    const slam::SettingsFile file = slam::read_settings_file(options.dataset.settings_path);
    file.apply_to(settings.frontend);
    if (file.th_depth) settings.th_depth = *file.th_depth;
  }
  if (options.levels > 0) settings.frontend.levels = options.levels;
  const int cell = options.cell > 0 ? options.cell : fitted_cell;
  settings.frontend.cell_width = settings.frontend.cell_height = cell;
  // Paced like a camera, tracking comes first and mapping uses the time between frames. As fast
  // as possible there is no time between frames: mapping then shares the cores equally, or local
  // bundle adjustment would hardly ever run (docs/USER_GUIDE.md, "Scheduling").
  const bool paced = options.rate > 0.0;
  settings.mapping_thread_idle_priority = paced;
  settings.mapping_yields_to_tracking = paced;
  // Unpaced, mapping and loop closing share the core the frontend leaves them (frontend_threads),
  // mapping first, and yield it when the frame path wants two.
  settings.mapping_thread_nice = paced ? 0 : kUnpacedMappingNice;
  settings.loop_closing_thread_nice = paced ? 0 : kUnpacedLoopClosingNice;
  settings.loop_closing = options.loop_closing && !options.localization;
  settings.localization_only = options.localization;
  settings.global_bundle_adjustment = options.global_ba;
  settings.mapping_threads = options.mapping_threads;
  settings.bundle_adjustment_every = options.ba_every;
  settings.keyframes_while_mapping = options.keyframes_while_mapping;
  settings.queued_keyframes_follow_ba = options.queued_follow_ba;
  settings.tracking_releases_map_lock = options.tracking_releases_map_lock;
  settings.realtime_bundle_adjustment_tolerance = options.ba_tolerance;
  settings.realtime_bundle_adjustment_steps = options.ba_steps;
  settings.keyframe_queue_limit = options.keyframe_queue;
  settings.min_frames_between_keyframes = options.keyframe_gap;
  settings.projection_on_backend = options.projection_on_backend;
  settings.validate();
  return settings;
}

/// The cpu backend's worker threads: --threads, else all hardware threads, except as fast as
/// possible in the realtime mode, where one is left to local mapping and loop closing. On 2 cores
/// the frontend then runs on one thread, mapping on the other core at nice 5 and loop closing at
/// 19 (make_settings), and no frontend step waits for a worker that mapping pushed off its core
/// (docs/BENCHMARKS.md: the frame rate and the keyframes both rose).
int frontend_threads(const SlamRunOptions& options) {
  if (options.threads > 0) return options.threads;
  if (options.rate > 0.0 || options.mode != slam::RunMode::realtime) return 0;  // 0: all
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()) - 1);
}

std::string format_ms(const Quantiles& q) {
  char text[96];
  std::snprintf(text, sizeof text, "%9.2f %9.2f %9.2f %8zu", q.median_ms, q.p95_ms, q.mean_ms, q.count);
  return text;
}

}  // namespace

SlamRunSummary run_slam(const SlamRunOptions& options) {
  // Every output is checked before anything is read or run (created once the input is known good).
  check_output_folder("--out", options.out);
  if (!options.save_map.empty()) check_output_file("--save-map", options.save_map, options.out);
  if (!options.json.empty()) check_output_file("--json", options.json, options.out);
  if (!options.export_map.empty()) check_output_file("--export-map", options.export_map, options.out);
  const auto dataset = slam::open_dataset(options.kind, options.path, options.dataset);
  if (dataset->size() == 0) throw CliError("the dataset " + options.path + " has no stereo frames");
  if (options.first >= dataset->size()) {
    throw CliError("--first " + std::to_string(options.first) + " is past the last frame (the dataset has " +
                   std::to_string(dataset->size()) + " frames)");
  }
  const std::size_t end =
      options.count == 0 ? dataset->size() : std::min(dataset->size(), options.first + options.count);
  const slam::SlamSettings settings = make_settings(options, *dataset);
  if (options.localization && options.load_map.empty()) {
    throw CliError("--localization tracks on a saved map: give it with --load-map FILE");
  }
  prepare_output_folder("--out", options.out);

  BackendOptions backend_options;
  backend_options.device = options.device;
  backend_options.threads = frontend_threads(options);
  std::unique_ptr<Backend> backend = BackendRegistry::instance().create(options.backend, backend_options);

  std::printf("dataset   %s\n", dataset->describe().c_str());
  std::printf("camera    %s\n", settings.camera.describe().c_str());
  std::printf("backend   %s on %s%s%s\n", backend->name().c_str(), backend->device_name().c_str(),
              settings.projection_on_backend ? "" : "; tracking's projection matching on the host",
              options.pinned_input ? "" : "; each pair copied on submit (--input copy)");
  std::printf("mode      %s, frames %zu..%zu, %d pyramid levels, scale %.2f, FAST threshold %d, %d-px cells\n",
              options.mode == slam::RunMode::realtime ? "realtime" : "deterministic", options.first, end - 1,
              settings.frontend.levels, settings.frontend.scale_factor, settings.frontend.fast_threshold,
              settings.frontend.cell_width);
  if (settings.min_frames_between_keyframes > 0) {
    std::printf("keyframes at least %d frames apart unless tracking is weak (--keyframe-gap)\n",
                settings.min_frames_between_keyframes);
  }
  if (options.rate > 0.0) {
    std::printf("playback  %.3gx the recorded frame rate (frames are handed over at their time stamps)\n",
                options.rate);
  }
  if (options.mode == slam::RunMode::realtime) {
    if (settings.mapping_thread_idle_priority) {
      std::printf("threads   mapping at idle priority, pausing while a frame is tracked; loop closing at nice %d\n",
                  settings.loop_closing_thread_nice);
    } else {
      std::printf("threads   mapping at nice %d, loop closing at nice %d; keyframes while mapping: %s\n",
                  settings.mapping_thread_nice, settings.loop_closing_thread_nice,
                  settings.keyframes_while_mapping ? "on" : "off");
    }
  }
  std::fflush(stdout);

  double summary_map_load_ms = 0.0;
  // As fast as possible, the frontend of the next pair is submitted before the current pair is
  // tracked (on a GPU backend the device computes it meanwhile); paced like a camera the next pair
  // does not exist yet while the current one is tracked. The results are the same either way.
  const bool paced = options.rate > 0.0;
  slam::SystemOptions system_options;
  system_options.frontend_in_flight = paced ? 1 : 2;
  slam::System system(settings, *backend, options.mode, system_options);
  if (!options.load_map.empty()) {
    const auto load_start = std::chrono::steady_clock::now();
    system.load_map(options.load_map);
    summary_map_load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - load_start).count();
    std::lock_guard lock(system.map().mutex);
    std::printf("map       %s: %zu keyframes, %zu map points, loaded in %.0f ms%s\n", options.load_map.c_str(),
                system.map().num_keyframes(), system.map().num_points(), summary_map_load_ms,
                options.localization ? "; localisation only (nothing is added)" : "");
    std::fflush(stdout);
  }
  const std::size_t total = end - options.first;
  const std::size_t progress_every = std::max<std::size_t>(1, total / 20);
  SlamRunSummary summary;
  summary.map_load_ms = summary_map_load_ms;
  slam::TrackingState previous = slam::TrackingState::not_initialized;
  std::string waiting_reason;
  std::vector<std::size_t> relocalised_frames;
  const auto run_start = std::chrono::steady_clock::now();
  const double cpu_start_s = process_cpu_seconds();
  const ThreadCpuSnapshot threads_at_start = thread_cpu_snapshot();
  // As fast as possible, up to read_ahead pairs are read (and for EuRoC rectified) on threads of
  // their own while frames are processed (decoding two PNG images takes longer than a GPU frame).
  // Paced like a camera, a pair is read when it is due: a camera delivers decoded images, so
  // reading files must not compete with SLAM for the cores while a frame is processed.
  const std::size_t read_ahead =
      paced ? 0 : std::clamp<std::size_t>(std::thread::hardware_concurrency() / 2, 1, 4);
  PairReader reader(*dataset, system, *backend, options.first, end, read_ahead, options.pinned_input);
  double first_time_s = 0.0, last_time_s = 0.0;
  const auto submit_next = [&](std::size_t i) {
    const PairReader::Slot& pair = reader.next();
    if (i == options.first) first_time_s = pair.time_s;
    last_time_s = pair.time_s;
    if (paced) {
      // Like a camera: the pair is not available before its time stamp (scaled by the rate).
      const auto due = run_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                       std::chrono::duration<double>((pair.time_s - first_time_s) / options.rate));
      std::this_thread::sleep_until(due);
    }
    reader.submit(system, pair);
  };
  const bool ahead = system.frontend_in_flight() > 1;
  submit_next(options.first);
  for (std::size_t i = options.first; i < end; ++i) {
    if (ahead && i + 1 < end) submit_next(i + 1);  // pair i+1's frontend runs while pair i is tracked
    const slam::TrackingResult result = system.track_next();
    reader.tracked(i + 1);
    if (!ahead && i + 1 < end) submit_next(i + 1);
    ++summary.frames;
    if (result.state == slam::TrackingState::ok) ++summary.tracked;
    if (result.state == slam::TrackingState::lost) {
      ++summary.lost;
      if (previous != slam::TrackingState::lost) {
        std::fprintf(stderr, "frame %zu: tracking LOST: %s\n", i, result.lost_reason.c_str());
      }
    }
    if (result.relocalised) {
      ++summary.relocalisations;
      relocalised_frames.push_back(i);
      std::fprintf(stderr, "frame %zu: %s\n", i, result.lost_reason.c_str());
    }
    if (result.state == slam::TrackingState::not_initialized) waiting_reason = result.lost_reason;
    previous = result.state;
    if (summary.frames % SlamRunSummary::kMemorySampleFrames == 0 || i + 1 == end) {
      std::lock_guard lock(system.map().mutex);
      summary.memory.push_back({summary.frames, resident_mib(), system.map().num_keyframes(), system.map().num_points()});
    }
    if (!options.quiet && (summary.frames % progress_every == 0 || i + 1 == end)) {
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
      std::size_t keyframes = 0, points = 0;
      {
        std::lock_guard lock(system.map().mutex);
        keyframes = system.map().num_keyframes();
        points = system.map().num_points();
      }
      std::fprintf(stderr,
                   "frame %zu/%zu  %.1f frames/s  %s  inliers %d  keyframes %zu  map points %zu  loops %zu  "
                   "relocalisations %zu  memory %.0f MiB\n",
                   summary.frames, total, summary.frames / std::max(seconds, 1e-9), slam::to_string(result.state),
                   result.matches_local_map, keyframes, points, system.loop_closer().loops_closed(),
                   summary.relocalisations, resident_mib());
    }
  }
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
  summary.cpu_s = process_cpu_seconds() - cpu_start_s;
  const std::vector<std::pair<std::string, double>> cpu_by_thread =
      thread_cpu_between(threads_at_start, thread_cpu_snapshot(), summary.cpu_s);
  system.finish();
  summary.peak_resident_mib = peak_resident_mib();
  if (!options.save_map.empty()) {
    system.save_map(options.save_map);
    std::printf("map       saved to %s\n", options.save_map.c_str());
  }

  const slam::Trajectory trajectory = system.trajectory();
  const std::string tum_path = (fs::path(options.out) / "trajectory_tum.txt").string();
  const std::string kitti_path = (fs::path(options.out) / "trajectory_kitti.txt").string();
  const std::string keyframes_path = (fs::path(options.out) / "keyframes_tum.txt").string();
  slam::write_trajectory(tum_path, trajectory, slam::TrajectoryFormat::tum);
  slam::write_trajectory(kitti_path, trajectory, slam::TrajectoryFormat::kitti);
  slam::write_kitti_times((fs::path(options.out) / "trajectory_times.txt").string(), trajectory);
  slam::write_trajectory(keyframes_path, system.keyframe_trajectory(), slam::TrajectoryFormat::tum);
  slam::write_file_atomically((fs::path(options.out) / "frames.csv").string(),
                              frame_log_csv(options.first, system.frame_times(), system.results(), reader.input_wait_ns()));
  slam::write_file_atomically((fs::path(options.out) / "mapping.csv").string(), mapping_log_csv(system.mapper().times()));
  slam::MapCloud cloud;  // for the export and the top view: the map the counts describe
  {
    std::lock_guard lock(system.map().mutex);
    summary.keyframes = system.map().num_keyframes();
    summary.map_points = system.map().num_points();
    cloud = slam::map_cloud(system.map());
  }

  // Per-stage timing.
  std::vector<std::int64_t> frontend_ns, stereo_ns, tracking_ns, frame_ns, local_map_ns, triangulate_ns, fuse_ns, ba_ns;
  std::vector<std::int64_t> map_wait_ns, unlocked_ns, relock_wait_ns, motion_ns, track_local_ns, keyframe_ns;
  std::vector<std::int64_t> mapping_wait_ns, mapping_lock_wait_ns;
  const bool stereo_separated = system.frontend_in_flight() == 1;  // pipelined frames are not profiled
  for (const slam::FrameTimes& t : system.frame_times()) {
    frontend_ns.push_back(t.frontend_ns);
    if (stereo_separated) stereo_ns.push_back(t.stereo_ns);
    tracking_ns.push_back(t.tracking_ns);
    mapping_wait_ns.push_back(t.mapping_wait_ns);
    frame_ns.push_back(t.total_ns);
  }
  for (const slam::TrackingResult& r : system.results()) {
    map_wait_ns.push_back(r.map_wait_ns);
    unlocked_ns.push_back(r.unlocked_ns);
    relock_wait_ns.push_back(r.relock_wait_ns);
    motion_ns.push_back(r.track_motion_ns);
    track_local_ns.push_back(r.track_local_map_ns);
    keyframe_ns.push_back(r.keyframe_ns);
  }
  for (const slam::MappingTimes& t : system.mapper().times()) {
    local_map_ns.push_back(t.total_ns - t.bundle_adjustment_ns);
    triangulate_ns.push_back(t.triangulate_ns);
    fuse_ns.push_back(t.fuse_ns);
    ba_ns.push_back(t.bundle_adjustment_ns);
    mapping_lock_wait_ns.push_back(t.lock_wait_ns);
  }
  // In the order printed and written.
  const std::vector<std::pair<std::string, Quantiles>> stages = {
      {"frontend", quantiles(frontend_ns)},         {"stereo", quantiles(stereo_ns)},
      {"tracking", quantiles(tracking_ns)},         {"map lock wait", quantiles(map_wait_ns)},
      {"track motion", quantiles(motion_ns)},       {"track local map", quantiles(track_local_ns)},
      {"without map lock", quantiles(unlocked_ns)}, {"map lock retake", quantiles(relock_wait_ns)},
      {"keyframe", quantiles(keyframe_ns)},         {"local map", quantiles(local_map_ns)},
      {"triangulation", quantiles(triangulate_ns)}, {"fusion", quantiles(fuse_ns)},
      {"BA", quantiles(ba_ns)},                     {"mapping lock wait", quantiles(mapping_lock_wait_ns)},
      {"input wait", quantiles(reader.input_wait_ns())},
      {"mapping wait", quantiles(mapping_wait_ns)},
      {"frame", quantiles(frame_ns)}};
  summary.median_frame_ms = stages.back().second.median_ms;
  if (options.rate > 0.0 && summary.frames > 1) {
    // A frame is late when processing it took longer than the time to the next frame.
    const std::vector<slam::FrameTimes>& times = system.frame_times();
    const double span_s = std::max(1e-9, (last_time_s - first_time_s) / options.rate);
    const double interval_ns = 1e9 * span_s / static_cast<double>(summary.frames - 1);
    for (const slam::FrameTimes& t : times) {
      if (static_cast<double>(t.total_ns) > interval_ns) ++summary.late_frames;
    }
  }

  std::printf("\nframes %zu, tracked %zu, lost %zu; keyframes %zu, map points %zu\n", summary.frames,
              summary.tracked, summary.lost, summary.keyframes, summary.map_points);
  if (summary.keyframes == 0 && !waiting_reason.empty()) {
    std::printf("never initialised; last frame: %s\n", waiting_reason.c_str());
  }
  std::printf("\nstage (ms)            median       p95      mean    count\n");
  for (const auto& [name, q] : stages) {
    if (q.count == 0 && name == "stereo") {
      std::printf("%-17s (inside the frontend; not timed apart while frames are pipelined)\n", name.c_str());
      continue;
    }
    std::printf("%-17s %s\n", name.c_str(), format_ms(q).c_str());
  }
  std::printf("(frontend includes stereo matching%s;\n tracking = map lock wait + track motion"
              " + track local map + keyframe, the track steps including the time without the map lock"
              " and waiting to retake it;"
              " frame = frontend + tracking%s;\n local map (which includes triangulation and fusion) and BA are per keyframe;"
              " mapping lock wait is the part of both that local mapping spent waiting to take the map's lock;"
              " input wait = the frames' loop waiting for the next pair from the reader, outside frame)\n",
              stereo_separated ? "" : " and is the host's share: the device works on the next pair while one is tracked",
              options.mode == slam::RunMode::deterministic ? " + local mapping of new keyframes"
                                                            : " + mapping wait (--keyframe-queue)");
  if (options.rate > 0.0) {
    std::printf("frames that took longer than the frame interval at %.3gx: %zu of %zu\n", options.rate,
                summary.late_frames, summary.frames);
  }
  const double frames = static_cast<double>(std::max<std::size_t>(summary.frames, 1));
  const double cpu_per_frame_s = summary.cpu_s / frames;
  std::printf("throughput %zu frames in %.2f s: %.1f frames/s; host CPU %.4f s per frame (%.2f cores busy",
              summary.frames, summary.wall_s, summary.frames / std::max(summary.wall_s, 1e-9), cpu_per_frame_s,
              summary.cpu_s / std::max(summary.wall_s, 1e-9));
  if (summary.frames > 1 && last_time_s > first_time_s) {
    const double recorded_fps = static_cast<double>(summary.frames - 1) / (last_time_s - first_time_s);
    std::printf("; %.1f %% of one core at the recorded %.3g frames/s", 100.0 * cpu_per_frame_s * recorded_fps,
                recorded_fps);
  }
  std::printf("); peak memory %.0f MiB\n", summary.peak_resident_mib);
  if (const std::string line = thread_cpu_text(cpu_by_thread, reader.cpu_s(), frames); !line.empty()) {
    std::printf("%s\n", line.c_str());
  }

  const LoopReport loops =
      report_loop_closing(system.loop_closer(), options.loop_closing, options.first, relocalised_frames);
  summary.loops_detected = loops.detected;
  summary.loops_closed = loops.closed;
  summary.global_ba_runs = loops.global_ba_runs;

  if (!trajectory.empty()) {
    double farthest = 0.0;
    const Eigen::Vector3d start = trajectory.poses.front().pose.translation();
    for (const slam::StampedPose& p : trajectory.poses) farthest = std::max(farthest, (p.pose.translation() - start).norm());
    std::printf("estimated path length %.4f m; farthest from the first pose %.4f m\n", trajectory.path_length_m(),
                farthest);
  }

  std::string ate_json = "null";
  std::optional<slam::EvaluationResult> evaluation;
  if (dataset->ground_truth() && trajectory.size() >= slam::kMinimumPairs) {
    try {
      const slam::EvaluationResult& eval =
          evaluation.emplace(slam::evaluate(*dataset->ground_truth(), trajectory));
      summary.has_ate = true;
      summary.ate_rmse_m = eval.ate.translation_m.rmse;
      summary.path_length_m = eval.matched_path_length_m;
      // The pose count says how many frames the figure covers: frames without a pose are named
      // here, on the ATE line itself, and again in the warning below.
      const std::size_t missing = summary.frames - std::min(summary.frames, summary.tracked);
      std::printf("\nATE (SE(3)-aligned, %zu poses of %zu frames%s): RMSE %.4f m, median %.4f m, max %.4f m",
                  eval.association.matched(), summary.frames,
                  missing == 0 ? "" : ("; " + std::to_string(missing) + " frames without a pose are not in it").c_str(),
                  summary.ate_rmse_m, eval.ate.translation_m.median, eval.ate.translation_m.max);
      if (summary.path_length_m >= 1.0) {
        std::printf(" (RMSE = %.3f %% of the %.1f m path)", 100.0 * summary.ate_rmse_m / summary.path_length_m,
                    summary.path_length_m);
      }
      std::printf("\n");
      if (summary.frames > summary.tracked) {
        std::printf("WARNING: %zu of %zu frames have no pose (lost or before initialisation) and are not in the ATE\n",
                    summary.frames - summary.tracked, summary.frames);
      }
      char text[256];
      std::snprintf(text, sizeof text,
                    "{\"poses\": %zu, \"rmse_m\": %.6f, \"median_m\": %.6f, \"max_m\": %.6f, \"path_length_m\": %.3f}",
                    eval.association.matched(), summary.ate_rmse_m, eval.ate.translation_m.median,
                    eval.ate.translation_m.max, summary.path_length_m);
      ate_json = text;
    } catch (const slam::EvaluationError& e) {
      std::printf("\nATE not computed: %s\n", e.what());
    }
  }
  std::printf("\nwrote %s, %s (+ trajectory_times.txt), %s, frames.csv, mapping.csv\n", tum_path.c_str(), kitti_path.c_str(),
              keyframes_path.c_str());
  MapOutputOptions map_outputs;
  map_outputs.export_path = options.export_map;
  map_outputs.colouring = options.export_colouring;
  map_outputs.top_view_path = (fs::path(options.out) / "map_top.png").string();
  map_outputs.title = "PortaSLAM run on " + options.path + ", frames " + std::to_string(options.first) + " to " +
                      std::to_string(end - 1) +
                      (options.load_map.empty() ? "" : ", on the map " + options.load_map);
  const slam::Trajectory* ground_truth = dataset->ground_truth() ? &*dataset->ground_truth() : nullptr;
  const MapReport map_report =
      write_map_outputs(cloud, trajectory, ground_truth, evaluation ? &*evaluation : nullptr, map_outputs);
  summary.exported_vertices = map_report.exported.vertices();

  const std::string json_path = options.json.empty() ? (fs::path(options.out) / "summary.json").string() : options.json;
  std::ostringstream json;
  json << "{\n  \"dataset\": \"" << options.path << "\",\n  \"backend\": \"" << options.backend
       << "\",\n  \"mode\": \"" << (options.mode == slam::RunMode::realtime ? "realtime" : "deterministic")
       << "\",\n  \"frames\": " << summary.frames << ",\n  \"tracked\": " << summary.tracked
       << ",\n  \"lost\": " << summary.lost << ",\n  \"keyframes\": " << summary.keyframes
       << ",\n  \"map_points\": " << summary.map_points << ",\n  \"stages_ms\": {";
  bool first = true;
  for (const auto& [name, q] : stages) {
    json << (first ? "\n" : ",\n") << "    \"" << name << "\": {\"median\": " << q.median_ms
         << ", \"p95\": " << q.p95_ms << ", \"mean\": " << q.mean_ms << ", \"count\": " << q.count << "}";
    first = false;
  }
  json << "\n  },\n  \"rate\": " << options.rate << ",\n  \"late_frames\": " << summary.late_frames
       << ",\n  \"throughput\": {\"wall_s\": " << summary.wall_s << ", \"frames_per_s\": "
       << summary.frames / std::max(summary.wall_s, 1e-9) << ", \"cpu_s\": " << summary.cpu_s
       << ", \"cpu_s_per_frame\": " << summary.cpu_s / frames << ", \"peak_resident_mib\": "
       << summary.peak_resident_mib << ", \"cpu\": " << thread_cpu_json(cpu_by_thread, reader.cpu_s()) << "}"
       << ",\n  " << loops.json << ",\n  " << map_report.json << ",\n  \"memory\": [";
  for (std::size_t k = 0; k < summary.memory.size(); ++k) {
    const SlamRunSummary::MemorySample& m = summary.memory[k];
    json << (k == 0 ? "\n" : ",\n") << "    {\"frame\": " << m.frame << ", \"resident_mib\": " << m.resident_mib
         << ", \"keyframes\": " << m.keyframes << ", \"map_points\": " << m.map_points << "}";
  }
  json << "\n  ],\n  \"ate\": " << ate_json << "\n}\n";
  try {
    slam::write_file_atomically(json_path, json.str());
  } catch (const slam::AtomicWriteError& e) {
    throw CliError(e.what());
  }
  return summary;
}

std::string slam_run_options_usage() {
  return "  --settings FILE     ORB-SLAM2-style YAML settings (camera for folder datasets; ORBextractor\n"
         "                      levels/scale/threshold; ThDepth; LEFT/RIGHT rectification for EuRoC)\n"
         "  --ground-truth FILE ground truth to evaluate against (any trajectory format)\n"
         "  --backend NAME      cpu (default), cuda, vulkan or opencl\n"
         "  --device D          device index or name substring for a GPU backend\n"
         "  --threads N         cpu backend worker threads (default: all; as fast as possible in\n"
         "                      the realtime mode all but one, left to mapping)\n"
         "  --mapping-threads N local mapping's threads for linking, triangulation, fusion and local\n"
         "                      BA (default 0: half the hardware threads, at most 8, with 8 or more;\n"
         "                      else 1); same map\n"
         "  --keyframe-queue N  realtime: tracking waits before a frame while N keyframes wait for\n"
         "                      local mapping (default 2; 0: never, as ORB-SLAM2)\n"
         "  --ba-every N        realtime: local BA on at least every Nth keyframe even while more\n"
         "                      wait (default 4; 0: only when none waits, as ORB-SLAM2)\n"
         "  --ba-tolerance X    realtime: local BA ends a stage when an iteration lowers its cost by\n"
         "                      at most X of it, 0 < X < 1 (default 0.001; deterministic: 1e-6)\n"
         "  --ba-steps N        realtime: a local BA right after the last keyframe's runs N steps in\n"
         "                      one stage, then drops the outliers (default 1; at most 100); a BA\n"
         "                      after skipped ones, and every BA with 0, runs ORB-SLAM2's 5 + 10\n"
         "  --keyframe-gap N    a frame that tracks well becomes a keyframe only N or more frames\n"
         "                      after the last one (default 0, as ORB-SLAM2 stereo; at most 10):\n"
         "                      less mapping CPU, poses between keyframes from tracking alone\n"
         "  --keyframes-while-mapping on|off\n"
         "                      realtime: a keyframe the scene needs is made while mapping is busy\n"
         "                      and none waits (default on; off: only when mapping is idle, as\n"
         "                      ORB-SLAM2)\n"
         "  --queued-follow-ba on|off\n"
         "                      realtime: keyframes waiting for local mapping follow the\n"
         "                      correction of each local BA of two stages written back, with\n"
         "                      their new points (default on; off: they stay, as ORB-SLAM2)\n"
         "  --tracking-map-lock frame|steps\n"
         "                      realtime: tracking holds the map's lock for the whole frame\n"
         "                      (default frame, as ORB-SLAM2), or lets it go while it computes on\n"
         "                      copies, its pose optimisations and projection matching (steps:\n"
         "                      mapping does more meanwhile; more accurate, fewer frames/s)\n"
         "  --projection-match WHERE\n"
         "                      backend (default: the backend's projection-match kernel) or host:\n"
         "                      where tracking matches map points to the frame; same matches\n"
         "  --input HOW         pinned (default: each pair is read into images the backend reads\n"
         "                      where they lie, pinned host memory on cuda) or copy (the frontend\n"
         "                      copies each pair on submit); same results\n"
         "  --mode M            realtime (default: tracking and mapping threads) or deterministic\n"
         "                      (mapping completes after each keyframe; same input, same bytes)\n"
         "  --out DIR           output folder (default portaslam-run): trajectory_tum.txt,\n"
         "                      trajectory_kitti.txt + trajectory_times.txt, keyframes_tum.txt, summary.json,\n"
         "                      frames.csv (per frame: inliers, mapping queue, stage times in ms),\n"
         "                      mapping.csv (per keyframe: local mapping's step times in ms)\n"
         "  --first N           first frame (default 0)\n"
         "  --frames N          number of frames (default: all)\n"
         "  --levels N          pyramid levels (default 8)\n"
         "  --cell N            culling cell size in pixels (default: fit to the image, 28 at 1242x375,\n"
         "                      14 at 640x194: sqrt(width * height / 594) in [8, 32])\n"
         "  --json FILE         summary JSON (default <out>/summary.json)\n"
         "  --quiet             no progress lines\n"
         "  --rate R            hand frames over at R x the recorded frame rate, as a camera would\n"
         "                      (1 = real time); default 0 = as fast as possible\n"
         "  --no-loop-closing   no loop detection or correction (visual odometry with local BA;\n"
         "                      relocalisation still works)\n"
         "  --no-global-ba      close loops without the global bundle adjustment after each\n"
         "  --save-map FILE     write the map at the end (versioned binary; see portaslam map info)\n"
         "  --load-map FILE     start on a saved map: the first frame relocalises in it, mapping goes on\n"
         "  --localization      with --load-map: track and relocalise on the map, add nothing to it\n" +
         map_output_options_usage();
}

bool parse_slam_run_option(const std::string& option, ArgumentCursor& cursor, SlamRunOptions& options) {
  if (option == "--settings") {
    options.dataset.settings_path = cursor.value(option);
  } else if (option == "--ground-truth") {
    options.dataset.ground_truth_path = cursor.value(option);
  } else if (option == "--backend") {
    options.backend = cursor.value(option);
  } else if (option == "--device") {
    options.device = cursor.value(option);
  } else if (option == "--threads") {
    options.threads = parse_threads(option, cursor.value(option));
  } else if (option == "--mapping-threads") {
    options.mapping_threads = parse_int(option, cursor.value(option), 0, slam::SlamSettings::kMaxMappingThreads);
  } else if (option == "--keyframe-queue") {
    options.keyframe_queue = parse_int(option, cursor.value(option), 0, slam::SlamSettings::kMaxKeyframeQueueLimit);
  } else if (option == "--keyframe-gap") {
    const int most = slam::SlamSettings{}.max_frames_between_keyframes;
    options.keyframe_gap = parse_int(option, cursor.value(option), 0, most);
  } else if (option == "--keyframes-while-mapping") {
    const std::string value = cursor.value(option);
    if (value != "on" && value != "off") {
      throw CliError("--keyframes-while-mapping takes on or off, got '" + value + "'");
    }
    options.keyframes_while_mapping = value == "on";
  } else if (option == "--queued-follow-ba") {
    const std::string value = cursor.value(option);
    if (value != "on" && value != "off") throw CliError("--queued-follow-ba takes on or off, got '" + value + "'");
    options.queued_follow_ba = value == "on";
  } else if (option == "--tracking-map-lock") {
    const std::string value = cursor.value(option);
    if (value != "steps" && value != "frame") {
      throw CliError("--tracking-map-lock takes frame or steps, got '" + value + "'");
    }
    options.tracking_releases_map_lock = value == "steps";
  } else if (option == "--ba-every") {
    options.ba_every = parse_int(option, cursor.value(option), 0, slam::SlamSettings::kMaxBundleAdjustmentEvery);
  } else if (option == "--ba-steps") {
    options.ba_steps = parse_int(option, cursor.value(option), 0, slam::SlamSettings::kMaxBundleAdjustmentSteps);
  } else if (option == "--ba-tolerance") {
    const std::string text = cursor.value(option);
    options.ba_tolerance = parse_double(option, text);
    if (!(options.ba_tolerance > 0.0 && options.ba_tolerance < 1.0))
      throw CliError("option --ba-tolerance expects a number above 0 and below 1, got '" + text + "'");
  } else if (option == "--projection-match") {
    const std::string where = cursor.value(option);
    if (where != "backend" && where != "host") {
      throw CliError("--projection-match takes backend or host, got '" + where + "'");
    }
    options.projection_on_backend = where == "backend";
  } else if (option == "--input") {
    const std::string how = cursor.value(option);
    if (how != "pinned" && how != "copy") throw CliError("--input takes pinned or copy, got '" + how + "'");
    options.pinned_input = how == "pinned";
  } else if (option == "--mode") {
    const std::string mode = cursor.value(option);
    if (mode == "realtime") {
      options.mode = slam::RunMode::realtime;
    } else if (mode == "deterministic") {
      options.mode = slam::RunMode::deterministic;
    } else {
      throw CliError("--mode must be realtime or deterministic, got '" + mode + "'");
    }
  } else if (option == "--out") {
    options.out = cursor.value(option);
  } else if (option == "--first") {
    const int first = parse_int(option, cursor.value(option));
    if (first < 0) throw CliError("--first must be >= 0");
    options.first = static_cast<std::size_t>(first);
  } else if (option == "--frames") {
    const int count = parse_int(option, cursor.value(option));
    if (count < 1) throw CliError("--frames must be >= 1");
    options.count = static_cast<std::size_t>(count);
  } else if (option == "--levels") {
    options.levels = parse_int(option, cursor.value(option));
    if (options.levels < 1 || options.levels > 12) throw CliError("--levels must be in [1, 12]");
  } else if (option == "--json") {
    options.json = cursor.value(option);
  } else if (option == "--rate") {
    // Beyond [1/1000, 1000] the frame interval leaves the clock's range or rounds to nothing.
    const std::string text = cursor.value(option);
    options.rate = parse_double(option, text, 0.0, 1000.0);
    if (options.rate > 0.0 && options.rate < 1e-3) {
      throw CliError("option --rate expects 0 (as fast as possible) or a rate in [0.001, 1000] (1 = the recorded "
                     "frame rate), got '" + text + "'");
    }
  } else if (option == "--cell") {
    options.cell = parse_int(option, cursor.value(option));
    if (options.cell < 1 || options.cell > 1024) throw CliError("--cell must be in [1, 1024] (pixels)");
  } else if (option == "--save-map") {
    options.save_map = cursor.value(option);
  } else if (option == "--load-map") {
    options.load_map = cursor.value(option);
  } else if (option == "--localization" || option == "--localisation") {
    options.localization = true;
  } else if (option == "--export-map") {
    options.export_map = cursor.value(option);
  } else if (option == "--export-map-colour" || option == "--export-map-color") {
    const std::string name = cursor.value(option);
    const auto colouring = slam::parse_map_colouring(name);
    if (!colouring) throw CliError(option + " must be height or keyframe, got '" + name + "'");
    options.export_colouring = *colouring;
  } else if (option == "--no-loop-closing") {
    options.loop_closing = false;
  } else if (option == "--no-global-ba") {
    options.global_ba = false;
  } else if (option == "--quiet") {
    options.quiet = true;
  } else {
    return false;
  }
  return true;
}

}  // namespace porta::app
