// Settings of the SLAM back end (tracking, local mapping) and the pipeline around it. Defaults
// follow ORB-SLAM2's stereo configuration; every field can come from an ORB-SLAM2 YAML file
// (settings_file.hpp) or the command line.
#pragma once

#include "porta/settings.hpp"
#include "porta/slam/place_recognition.hpp"
#include "porta/slam/stereo_camera.hpp"

namespace porta::slam {

enum class RunMode {
  realtime,       ///< tracking and local mapping in separate threads; mapping may lag behind
  deterministic,  ///< local mapping runs to completion after each keyframe: same input, same bytes
};

/// The culling cell size (level 0, square) for an image of `width` x `height`: about as many
/// level-0 cells as 28-px cells give a 1242x375 KITTI image (594), i.e. sqrt(W * H / 594) rounded,
/// clamped to [8, 32]. 640x194 gets 14 px, 621x188 14 px, 752x480 25 px, 1242x375 28 px. Culling keeps
/// one corner per cell, so smaller images need smaller cells for enough features to track (the
/// paper's Tables VII and VIII fit the cell size to the resolution).
int default_cell_size(int width, int height);

struct SlamSettings {
  StereoCamera camera;
  FrontendSettings frontend;  ///< levels, scale factor, FAST threshold, cells, stereo search range

  /// Stereo points closer than th_depth * baseline are "close" (reliable depth), as ORB-SLAM2's ThDepth.
  double th_depth = 35.0;
  /// Stereo initialisation needs at least this many stereo points. (ORB-SLAM2 asks for 500
  /// keypoints; our frontend keeps one corner per cell, so a 752x480 EuRoC frame has ~300 stereo
  /// points and 100 reliable ones are enough to start a map.)
  int min_init_stereo_points = 100;
  /// Matches below this disparity give no depth (too far).
  double min_disparity_px = 0.5;
  /// Local map tracking uses the compute backend's projection-match kernel (DESIGN.md §3.10);
  /// false runs the same search on the host (for comparison).
  bool projection_on_backend = true;
  /// Tracking is lost when fewer inliers than this remain after local-map tracking (ORB-SLAM2: 30).
  int min_tracked_inliers = 30;
  /// Most keyframes between forced keyframes (ORB-SLAM2: the frame rate).
  int max_frames_between_keyframes = 10;
  /// Fewest frames after a keyframe before a frame that tracks well (not weak, see
  /// Tracker::need_new_keyframe) may become the next one (ORB-SLAM2's mMinFrames; 0, its stereo
  /// value, lets the next frame). Fewer keyframes, each with less local mapping to do: the CPU a
  /// paced camera costs falls, and the pose of every frame between keyframes is tracking's alone
  /// (docs/USER_GUIDE.md, "Keyframes"). At most max_frames_between_keyframes.
  int min_frames_between_keyframes = 0;
  /// Realtime mode, Linux: the mapping thread runs at idle priority (SCHED_IDLE), so that it uses
  /// the cores tracking leaves free and never delays a frame. false: the caller's priority.
  bool mapping_thread_idle_priority = true;
  /// Realtime mode, Linux: the nice values of the mapping thread (when not at idle priority) and of
  /// the loop-closing thread, each in [0, 19] (0 = the caller's). As fast as possible `run` sets 5
  /// and 19, with its cpu frontend on all hardware threads but one: on 2 cores the frame path then
  /// keeps one core, mapping takes most of the other and loop closing, which nothing waits for, the
  /// rest (docs/BENCHMARKS.md: with two frontend threads and nice 0, 46.6 frames/s; one thread and
  /// nice 10, 50.0; medians of 5 on 2 cores).
  int mapping_thread_nice = 0;
  int loop_closing_thread_nice = 0;
  static constexpr int kMaxNice = 19;
  /// Realtime mode: a keyframe the scene needs (tracking fell below 75 % of the reference
  /// keyframe's points, or too few close points) is also made while local mapping is busy, as
  /// long as no keyframe waits for it (it waits for the step under way, which is not interrupted).
  /// ORB-SLAM2 makes it only when mapping is idle, so as fast as possible, where mapping
  /// is never idle, the keyframes depended on the frame rate (368-377 of 1 000 frames on 2 cores
  /// against 474 deterministic, and an RPE 6-12 % above ORB-SLAM2's); with this, 465-471 (RPE
  /// 0.0101 -> 0.0090 m). false: ORB-SLAM2's rule.
  bool keyframes_while_mapping = true;
  /// Realtime mode: when a local BA is written back, the keyframes still queued for local mapping
  /// (or made while it ran) follow the correction of the keyframe it adjusted, with the points
  /// they made, as the frames tracked against that keyframe do. Tracking placed them against the
  /// map of before and no adjustment holds them, so without this the next frames are tracked
  /// against the adjusted window beside them where they were and land between the two. As fast as
  /// possible on an H100 it cut the RPE over one frame by 40-45 % (docs/BENCHMARKS.md, "Queued
  /// keyframes follow local BA"). Only after a local BA of two stages, not a single step
  /// (realtime_bundle_adjustment_steps). No effect in the deterministic mode (nothing waits).
  /// false: as ORB-SLAM2.
  bool queued_keyframes_follow_ba = true;
  /// Realtime mode: tracking lets the map's lock go while it computes on copies of map data (its
  /// pose-only optimisations and the projection matcher), so that local mapping takes it meanwhile
  /// (Tracker::release_map_lock_while_computing). false (the default): tracking holds it for the
  /// whole frame (ORB-SLAM2). As fast as possible, true maps more and tracks more slowly: on the
  /// 2-core machine ATE 0.210 -> 0.167 m and RPE 0.0084 -> 0.0080 m, at 47.2 instead of 50.0
  /// frames/s; on an H100 host 370 instead of 398 frames/s at the same ATE (medians,
  /// docs/BENCHMARKS.md). The deterministic mode always holds it: nothing runs beside tracking.
  bool tracking_releases_map_lock = false;
  /// Realtime mode: the mapping thread pauses while a frame is tracked unless keyframes wait
  /// (LocalMapper::tracking_started()).
  bool mapping_yields_to_tracking = true;
  /// Threads of local mapping's parallel steps (triangulation's epipolar searches, local bundle
  /// adjustment's loops): 0 = one per two hardware threads, at most 8, on a machine of 8 hardware
  /// threads or more, else 1 (a small machine's cores are the frontend's and tracking's). The map
  /// is the same for any count. Realtime mode uses them only while keyframes come faster than
  /// mapping completes them (at camera rate one thread keeps up, and more would only add CPU time).
  int mapping_threads = 0;
  static constexpr int kMaxMappingThreads = 64;
  /// mapping_threads with 0 resolved for this machine.
  int resolved_mapping_threads() const;
  /// Realtime mode: local bundle adjustment runs, to the end, at least on every Nth keyframe even
  /// while more keyframes wait. 0 = only when none waits (ORB-SLAM2: as fast as possible on a fast
  /// GPU, mapping then falls behind and skips it almost always; with 4 the median ATE of nine runs
  /// was 1.5x the deterministic run's there, against 3.3x with 0, docs/BENCHMARKS.md). At camera
  /// rate and in the deterministic mode keyframes rarely or never wait, so N changes nothing there.
  int bundle_adjustment_every = 4;
  static constexpr int kMaxBundleAdjustmentEvery = 1000;
  /// Realtime mode: local bundle adjustment ends a stage after an iteration that lowered the cost
  /// by at most this fraction of it (LocalBundleAdjustmentOptions::function_tolerance), in
  /// (0, 1). With 1e-3 instead of Ceres' 1e-6, as fast as possible on 2 cores, an adjustment took
  /// a fifth less time, more completed, and the RPE over one frame was 5-7 % lower (medians of
  /// five runs, docs/BENCHMARKS.md). The deterministic mode keeps 1e-6: the accuracy reference.
  double realtime_bundle_adjustment_tolerance = 1e-3;
  static constexpr double kDeterministicBundleAdjustmentTolerance = 1e-6;
  /// Realtime mode: a local bundle adjustment that follows one of the keyframe before runs at most
  /// this many Levenberg-Marquardt iterations in one stage with the robust loss, then drops the
  /// outliers as ORB-SLAM2 does after its first stage. Consecutive windows share most of their
  /// keyframes and points (a keyframe every ~2 frames on KITTI, ~40 in a window), so each
  /// adjustment continues the one before: a keyframe's pose gets a step from every window it is in.
  /// A local BA after keyframes went without one (mapping behind, `bundle_adjustment_every`) runs
  /// ORB-SLAM2's two stages (5 robust iterations, the outliers dropped, 10 more). 0: the two stages
  /// always. At camera rate on the 2-core machine, 1 cut local mapping's CPU by ~40 % at the same
  /// RPE (docs/BENCHMARKS.md, "Local BA in one step"). The deterministic mode runs the two stages.
  int realtime_bundle_adjustment_steps = 1;
  static constexpr int kMaxBundleAdjustmentSteps = 100;
  /// Realtime mode: before a frame is tracked, tracking waits while this many keyframes (or more)
  /// wait for local mapping, so that it never runs further ahead of the map. 0 = it never waits
  /// (ORB-SLAM2: with 3 queued it makes no keyframe, and as fast as possible on an H200 the map it
  /// tracked against thinned out until tracking was lost, in every run of one call; with 2, none
  /// lost, the same frame rate; docs/BENCHMARKS.md). At camera rate mapping keeps up: no wait.
  int keyframe_queue_limit = 2;
  static constexpr int kMaxKeyframeQueueLimit = 100;

  /// Loop closing (loop_closer.hpp): loops are detected, verified and corrected. false: local
  /// mapping only (the place-recognition database is still kept, for relocalisation).
  bool loop_closing = true;
  /// A global bundle adjustment over the whole map after each closed loop.
  bool global_bundle_adjustment = true;
  /// Localisation only (ORB-SLAM2's "only tracking"): frames are tracked against the map (a loaded
  /// one) and relocalised when lost, but no keyframe or point is added and nothing is optimised.
  bool localization_only = false;
  /// The place-recognition database (descriptor tree leaf size, match distance).
  PlaceRecognitionOptions place_recognition;

  double close_depth_m() const { return th_depth * camera.baseline_m; }
  /// Throws std::invalid_argument / SettingsError naming the bad field.
  void validate() const;
};

/// The settings `portaslam run` starts from for `camera` (before its options): the defaults
/// above, culling cells fit to the image size (default_cell_size) and a stereo search over every
/// disparity a point 0.5 m away or farther can have (capped at the image width and 4096).
SlamSettings default_settings(const StereoCamera& camera);

}  // namespace porta::slam
