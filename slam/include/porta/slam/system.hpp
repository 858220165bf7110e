// The whole stereo SLAM pipeline for one sequence: frontend on a compute backend, tracking, local
// mapping and loop closing (each in a thread, or all in the caller's thread in the deterministic
// mode), and the trajectory of every frame (DESIGN.md §6).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <vector>

#include "porta/backend.hpp"
#include "porta/frontend.hpp"
#include "porta/slam/dataset.hpp"
#include "porta/slam/local_mapper.hpp"
#include "porta/slam/loop_closer.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/map_file.hpp"
#include "porta/slam/slam_settings.hpp"
#include "porta/slam/tracker.hpp"

namespace porta::slam {

/// Per-frame stage times (nanoseconds).
struct FrameTimes {
  /// Both images: detection + description (incl. upload/download). Pipelined: the host's share,
  /// submit() plus the wait for the features in track_next() (the device's work overlaps tracking).
  std::int64_t frontend_ns = 0;
  std::int64_t stereo_ns = 0;    ///< stereo matching (inside the frontend; separated only when not pipelined)
  std::int64_t tracking_ns = 0;
  /// Realtime mode with SlamSettings::keyframe_queue_limit: waiting for local mapping to take a
  /// keyframe before tracking (inside total_ns).
  std::int64_t mapping_wait_ns = 0;
  std::int64_t total_ns = 0;     ///< frontend_ns + tracking (+ deterministic mapping): the frame's host time
};

/// A rectified stereo pair in input images of the System (System::make_input_image()): the
/// backend reads them where they lie (pinned host memory on cuda), with no host copy on submit.
struct StereoInput {
  std::size_t index = 0;
  double time_s = 0.0;
  InputImage left, right;
};

struct SystemOptions {
  /// Frames whose frontend may be submitted before the oldest is tracked (FrontendOptions::
  /// in_flight). 1: process() only, each stage timed separately. 2 or more: submit() / track_next()
  /// pipelining, with the same results.
  int frontend_in_flight = 1;
};

class System {
 public:
  /// Validates the settings (std::invalid_argument / SettingsError naming the field). `backend`
  /// must outlive the System.
  System(const SlamSettings& settings, Backend& backend, RunMode mode, SystemOptions options = {});
  ~System();  ///< stops the mapping thread
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  /// Runs one rectified stereo pair through the pipeline: submit(pair), then track_next().
  /// std::logic_error while pairs submitted earlier are pending.
  TrackingResult process(const StereoPair& pair);

  /// Pipelining (SystemOptions::frontend_in_flight > 1): enqueues the frontend of a pair (the
  /// images are copied before it returns) and returns; on a GPU backend the device computes it
  /// while the host goes on. std::invalid_argument for a pair of the wrong size; std::logic_error
  /// when frontend_in_flight pairs are pending already.
  void submit(const StereoPair& pair);
  /// As submit(const StereoPair&), without the copy: the images are read in place, so they must
  /// not change until track_next() has tracked this pair. std::invalid_argument for an image this
  /// System did not make (or one moved from).
  void submit(const StereoInput& pair);
  /// An image of the camera's size for submit(const StereoInput&), zero-filled: memory the backend
  /// reads directly (pinned on cuda). Fill it through InputImage::row() or assign(), on any
  /// thread; make them on the thread that calls submit().
  InputImage make_input_image() { return frontend_->make_input_image(); }
  /// Waits for the features of the oldest submitted pair and tracks it (std::logic_error when none
  /// is pending). Submitting pair t+1 before tracking pair t overlaps the two; the results are
  /// those of process() on the same pairs in the same order, byte for byte.
  TrackingResult track_next();
  /// Pairs submitted and not yet tracked.
  std::size_t pending() const { return pending_.size(); }
  int frontend_in_flight() const { return options_.frontend_in_flight; }
  /// Realtime mode: lets local mapping finish its queue and stops its thread. Called by the
  /// destructor; call it before reading the final trajectory.
  void finish();

  /// Loads a map saved by save_map() before the first frame (std::logic_error after it): the first
  /// frame then relocalises against it, and mapping continues on it (or only tracks, with
  /// settings.localization_only). Throws MapFileError for a bad file, or when the map's camera or
  /// pyramid (levels, scale factor) differ from this System's. Returns the file's contents.
  MapFileContents load_map(const std::string& path);
  /// Writes the map and the place-recognition database (map_file.hpp), atomically. Call after
  /// finish() in the realtime mode (std::logic_error otherwise): the threads must be done.
  void save_map(const std::string& path) const;

  /// T_world_cam of every processed frame that was tracked, recomputed from its reference
  /// keyframe's current pose (so it reflects bundle adjustment), in frame order.
  Trajectory trajectory() const;
  /// Keyframe poses (T_world_cam).
  Trajectory keyframe_trajectory() const;

  const std::vector<FrameTimes>& frame_times() const { return frame_times_; }
  const std::vector<TrackingResult>& results() const { return results_; }
  const LocalMapper& mapper() const { return *mapper_; }
  const LoopCloser& loop_closer() const { return *loop_closer_; }
  LoopCloser& loop_closer() { return *loop_closer_; }
  const Map& map() const { return map_; }

 private:
  struct FrameRecord {
    double time_s = 0.0;
    bool tracked = false;
    KeyFrame* reference = nullptr;
    SE3 T_c_ref = SE3::Identity();  ///< camera pose relative to its reference keyframe
  };
  struct Pending {
    double time_s = 0.0;
    std::int64_t submit_ns = 0;
  };
  void check_can_submit() const;  ///< std::logic_error after finish() or with in-flight pairs pending

  SlamSettings settings_;
  RunMode mode_;
  SystemOptions options_;
  std::deque<Pending> pending_;
  Backend& backend_;
  std::unique_ptr<Frontend> frontend_;
  Map map_;
  std::unique_ptr<LocalMapper> mapper_;
  std::unique_ptr<LoopCloser> loop_closer_;
  std::unique_ptr<Tracker> tracker_;
  std::vector<FrameRecord> records_;
  std::vector<FrameTimes> frame_times_;
  std::vector<TrackingResult> results_;
  bool finished_ = false;
};

}  // namespace porta::slam
