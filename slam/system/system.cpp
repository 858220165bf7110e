#include "porta/slam/system.hpp"

#include <chrono>
#include <stdexcept>

#include "porta/slam/elapsed.hpp"

namespace porta::slam {

System::System(const SlamSettings& settings, Backend& backend, RunMode mode, SystemOptions system_options)
    : settings_(settings), mode_(mode), options_(system_options), backend_(backend) {
  settings_.validate();
  if (options_.frontend_in_flight < 1 || options_.frontend_in_flight > FrontendOptions::kMaxInFlight) {
    throw std::invalid_argument("SystemOptions::frontend_in_flight must be in [1, " +
                                std::to_string(FrontendOptions::kMaxInFlight) + "], got " +
                                std::to_string(options_.frontend_in_flight));
  }
  // Stage profiling synchronises between kernels: it separates the stereo matching time for the
  // statistics and costs little one frame at a time, but it would stop a pipelined frame's work
  // from running while the host tracks, so only the unpipelined System profiles.
  FrontendOptions options;
  options.in_flight = options_.frontend_in_flight;
  options.profile_stages = options_.frontend_in_flight == 1;
  frontend_ = std::make_unique<Frontend>(backend_, settings_.frontend, settings_.camera.width,
                                         settings_.camera.height, options);
  mapper_ = std::make_unique<LocalMapper>(settings_, map_);
  loop_closer_ = std::make_unique<LoopCloser>(settings_, map_);
  mapper_->set_keyframe_processed([closer = loop_closer_.get()](KeyFrame* keyframe) { closer->insert_keyframe(keyframe); });
  // Tracking's projection matching on a queue of its own where the backend has one to spare: the
  // frame tracked does not wait for the next one's frontend work, queued on the slot's queues.
  tracker_ = std::make_unique<Tracker>(settings_, map_, *mapper_, backend_, frontend_->tables(), loop_closer_.get(),
                                       frontend_->spare_queue());
  tracker_->release_map_lock_while_computing(mode_ == RunMode::realtime &&
                                             settings_.tracking_releases_map_lock);
  // Localisation only: nothing is added to the map, so neither thread has work.
  if (mode_ == RunMode::realtime && !settings_.localization_only) {
    loop_closer_->start();
    mapper_->start();
  }
}

System::~System() { finish(); }

void System::finish() {
  if (finished_) return;
  finished_ = true;
  if (mode_ == RunMode::realtime) {
    mapper_->stop();  // drains its queue into loop closing
    loop_closer_->stop();
  } else {
    mapper_->process_all();
    loop_closer_->process_all();
  }
}

TrackingResult System::process(const StereoPair& pair) {
  if (!pending_.empty()) throw std::logic_error("System::process: pairs submitted earlier are pending (use track_next)");
  submit(pair);
  return track_next();
}

void System::submit(const StereoPair& pair) {
  const StereoCamera& camera = settings_.camera;
  if (pair.left.width() != camera.width || pair.left.height() != camera.height ||
      pair.right.width() != camera.width || pair.right.height() != camera.height) {
    throw std::invalid_argument("stereo pair " + std::to_string(pair.index) + " is " +
                                std::to_string(pair.left.width()) + "x" + std::to_string(pair.left.height()) +
                                " (right " + std::to_string(pair.right.width()) + "x" +
                                std::to_string(pair.right.height()) + ") but the camera is " +
                                std::to_string(camera.width) + "x" + std::to_string(camera.height));
  }
  check_can_submit();
  const auto start = std::chrono::steady_clock::now();
  frontend_->submit_stereo(pair.left.view(), pair.right.view());
  pending_.push_back({pair.time_s, elapsed_ns(start)});
}

void System::submit(const StereoInput& pair) {
  check_can_submit();
  const auto start = std::chrono::steady_clock::now();
  frontend_->submit_stereo(pair.left, pair.right);  // std::invalid_argument for a foreign image
  pending_.push_back({pair.time_s, elapsed_ns(start)});
}

void System::check_can_submit() const {
  if (finished_) throw std::logic_error("System::submit called after finish()");
  if (static_cast<int>(pending_.size()) >= options_.frontend_in_flight)
    throw std::logic_error("System::submit: " + std::to_string(pending_.size()) + " pairs are pending already");
}

TrackingResult System::track_next() {
  if (finished_) throw std::logic_error("System::track_next called after finish()");
  if (pending_.empty()) throw std::logic_error("System::track_next: no pair was submitted");
  const Pending pending = pending_.front();
  pending_.pop_front();
  const StereoCamera& camera = settings_.camera;
  // Realtime mode: mapping pauses at its next pause point while this frame is tracked.
  struct TrackingScope {
    LocalMapper* mapper;
    explicit TrackingScope(LocalMapper* m) : mapper(m) {
      if (mapper != nullptr) mapper->tracking_started();
    }
    ~TrackingScope() {
      if (mapper != nullptr) mapper->tracking_finished();
    }
    TrackingScope(const TrackingScope&) = delete;
    TrackingScope& operator=(const TrackingScope&) = delete;
  } scope(mode_ == RunMode::realtime ? mapper_.get() : nullptr);
  const auto start = std::chrono::steady_clock::now();
  FrameTimes times;
  const StereoFeatures stereo = frontend_->collect_stereo();
  times.frontend_ns = pending.submit_ns + elapsed_ns(start);
  times.stereo_ns = options_.frontend_in_flight == 1 ? frontend_->last_times().stereo_ns : 0;
  auto features = std::make_shared<const FrameFeatures>(
      FrameFeatures::from_frontend(stereo, frontend_->tables(), camera, settings_.min_disparity_px));

  if (mode_ == RunMode::realtime && settings_.keyframe_queue_limit > 0) {
    const auto wait_start = std::chrono::steady_clock::now();
    mapper_->wait_while_queued(static_cast<std::size_t>(settings_.keyframe_queue_limit));
    times.mapping_wait_ns = elapsed_ns(wait_start);
  }
  const auto track_start = std::chrono::steady_clock::now();
  TrackingResult result = tracker_->track(static_cast<std::uint64_t>(records_.size()), pending.time_s, features);
  times.tracking_ns = elapsed_ns(track_start);

  FrameRecord record;
  record.time_s = pending.time_s;
  if (result.state == TrackingState::ok && result.reference_keyframe != nullptr) {
    // Relative to the keyframe's pose as tracking saw it, not as it is now: local mapping may have
    // moved it since tracking let the lock go, and the frame then follows that correction.
    record.tracked = true;
    record.reference = result.reference_keyframe;
    record.T_c_ref = result.T_c_ref;
  }
  records_.push_back(record);

  // Deterministic mode: the map is complete for this keyframe before the next frame is tracked.
  if (mode_ == RunMode::deterministic && result.keyframe_inserted) {
    mapper_->process_all();
    loop_closer_->process_all();
  }
  times.total_ns = pending.submit_ns + elapsed_ns(start);
  frame_times_.push_back(times);
  results_.push_back(result);
  return result;
}

MapFileContents System::load_map(const std::string& path) {
  if (!records_.empty()) throw std::logic_error("System::load_map: frames were processed already");
  MapFileContents contents = slam::load_map(path, map_);
  check_map_camera(contents, settings_.camera, path);
  const FrontendSettings& mine = settings_.frontend;
  const FrontendSettings& theirs = contents.settings.frontend;
  if (mine.levels != theirs.levels || mine.scale_factor != theirs.scale_factor) {
    throw MapFileError("map file '" + path + "' was made with " + std::to_string(theirs.levels) +
                       " pyramid levels, scale factor " + std::to_string(theirs.scale_factor) + "; this run uses " +
                       std::to_string(mine.levels) + " levels, scale factor " + std::to_string(mine.scale_factor) +
                       " (its descriptors and scales would not compare)");
  }
  if (contents.place_database.empty()) {
    PlaceDatabase database(settings_.place_recognition);
    std::lock_guard lock(map_.mutex);
    for (const KeyFrame* k : map_.keyframes()) database.add(k->id, k->features->descriptors);
    loop_closer_->set_database(std::move(database));
  } else {
    try {
      loop_closer_->set_database(PlaceDatabase::deserialize(contents.place_database));
    } catch (const PlaceDatabaseError& e) {
      throw MapFileError("map file '" + path + "': section 'PLDB': " + e.what());
    }
  }
  tracker_->relocalise_next("a map was loaded from '" + path + "': relocalising against it");
  return contents;
}

void System::save_map(const std::string& path) const {
  if (mode_ == RunMode::realtime && !finished_ && !settings_.localization_only) {
    throw std::logic_error("System::save_map: call finish() first (the mapping threads are running)");
  }
  slam::save_map(path, map_, settings_, loop_closer_->serialize_database());
}

Trajectory System::trajectory() const {
  std::lock_guard lock(map_.mutex);
  Trajectory trajectory;
  for (const FrameRecord& record : records_) {
    if (!record.tracked) continue;
    // A culled reference keyframe keeps the last pose it had; the frames that referred to it
    // follow its good ancestor instead, which loop closing keeps correcting.
    SE3 T_c_ref = record.T_c_ref;
    const KeyFrame* reference = record.reference;
    while (reference->bad && reference->parent != nullptr) {
      T_c_ref = T_c_ref * reference->T_c_parent;
      reference = reference->parent;
    }
    const SE3 T_cw = T_c_ref * reference->T_cw;
    trajectory.poses.push_back({record.time_s, T_cw.inverse()});
  }
  return trajectory;
}

Trajectory System::keyframe_trajectory() const {
  std::lock_guard lock(map_.mutex);
  Trajectory trajectory;
  for (const KeyFrame* keyframe : map_.keyframes()) {
    trajectory.poses.push_back({keyframe->time_s, keyframe->T_cw.inverse()});
  }
  return trajectory;
}

}  // namespace porta::slam
