// LoopCloser: the queue, the threads and the order of the steps (loop_steps.hpp); see
// loop_closer.hpp for the locking scheme.
#include "porta/slam/loop_closer.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <utility>

#include "../system/thread_niceness.hpp"
#include "cpu/thread_name.hpp"
#include "loop_steps.hpp"
#include "porta/slam/elapsed.hpp"

namespace porta::slam {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

struct LoopCloser::Impl {
  Impl(const SlamSettings& settings)
      : pyramid(settings.frontend.levels, settings.frontend.scale_factor), database(settings.place_recognition) {}

  /// Removes the keyframes local mapping culled from the database (caller holds both locks).
  void purge_bad() {
    std::size_t kept = 0;
    for (KeyFrame* k : stored) {
      if (k->bad) {
        database.erase(k->id, k->features->descriptors);
      } else {
        stored[kept++] = k;
      }
    }
    stored.resize(kept);
  }

  const ScalePyramid pyramid;
  PlaceDatabase database;          // under database_mutex_
  std::vector<KeyFrame*> stored;   // keyframes in the database, under database_mutex_
  std::vector<loop::ConsistentGroup> groups;
  std::uint64_t last_loop_keyframe = 0;
  bool any_loop = false;
};

LoopCloser::LoopCloser(const SlamSettings& settings, Map& map)
    : settings_(settings), map_(map), impl_(std::make_unique<Impl>(settings)) {}

LoopCloser::~LoopCloser() { stop(); }

void LoopCloser::insert_keyframe(KeyFrame* keyframe) {
  if (keyframe == nullptr) throw std::invalid_argument("LoopCloser::insert_keyframe: keyframe is null");
  {
    std::lock_guard lock(queue_mutex_);
    queue_.push_back(keyframe);
  }
  queue_cv_.notify_one();
}

void LoopCloser::process_all() {
  if (thread_.joinable()) {
    throw std::logic_error("LoopCloser::process_all: the loop-closing thread is running (realtime mode)");
  }
  for (;;) {
    KeyFrame* keyframe = nullptr;
    {
      std::lock_guard lock(queue_mutex_);
      if (queue_.empty()) return;
      keyframe = queue_.front();
      queue_.pop_front();
    }
    process(keyframe);
  }
}

void LoopCloser::start() {
  if (thread_.joinable()) return;
  stop_requested_ = false;
  thread_ = std::thread(&LoopCloser::thread_main, this);
}

void LoopCloser::stop() {
  if (thread_.joinable()) {
    {
      std::lock_guard lock(queue_mutex_);
      stop_requested_ = true;
    }
    queue_cv_.notify_all();
    thread_.join();
  }
  // A running global BA finishes: the trajectory should carry it, as ORB-SLAM2's shutdown waits.
  if (global_ba_thread_.joinable()) global_ba_thread_.join();
}

bool LoopCloser::busy() const {
  std::lock_guard lock(queue_mutex_);
  return working_ || !queue_.empty() || global_ba_running_;
}

void LoopCloser::thread_main() {
  cpu::name_this_thread("porta-loop");
  detail::set_thread_nice(settings_.loop_closing_thread_nice);
  for (;;) {
    KeyFrame* keyframe = nullptr;
    {
      std::unique_lock lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return !queue_.empty() || stop_requested_; });
      if (queue_.empty()) break;
      keyframe = queue_.front();
      queue_.pop_front();
      working_ = true;
    }
    process(keyframe);
    std::lock_guard lock(queue_mutex_);
    working_ = false;
  }
}

std::vector<KeyFrame*> LoopCloser::relocalisation_candidates(const FrameFeatures& features) {
  std::lock_guard lock(database_mutex_);
  impl_->purge_bad();
  return loop::relocalisation_candidates(map_, impl_->database.query(features.descriptors));
}

void LoopCloser::set_database(PlaceDatabase database) {
  std::lock_guard map_lock(map_.mutex);
  std::lock_guard lock(database_mutex_);
  impl_->database = std::move(database);
  impl_->stored.clear();
  for (KeyFrame* k : map_.keyframes()) {
    if (impl_->database.contains(k->id)) impl_->stored.push_back(k);
  }
}

std::vector<std::uint8_t> LoopCloser::serialize_database() const {
  std::lock_guard lock(database_mutex_);
  return impl_->database.serialize();
}

void LoopCloser::process(KeyFrame* keyframe) {
  LoopTimes times;
  const auto start = Clock::now();
  // The map's lock (which tracking waits for) only where map objects are read: the database query
  // and the candidates' descriptor matching (milliseconds each) read the keyframes' immutable
  // features and run without it. Deterministic mode runs the same steps in the same order.
  std::vector<KeyFrame*> consistent;
  bool searching = false;
  {
    std::lock_guard map_lock(map_.mutex);
    if (keyframe->bad) return;
    std::lock_guard lock(database_mutex_);
    impl_->purge_bad();
    searching = settings_.loop_closing && map_.num_keyframes() > static_cast<std::size_t>(loop::kMinKeyframesBetweenLoops) &&
                (!impl_->any_loop || keyframe->id >= impl_->last_loop_keyframe + loop::kMinKeyframesBetweenLoops);
  }
  std::vector<PlaceScore> scores;
  {
    std::lock_guard lock(database_mutex_);
    if (searching) scores = impl_->database.query(keyframe->features->descriptors);
    impl_->database.add(keyframe->id, keyframe->features->descriptors);
    impl_->stored.push_back(keyframe);
  }
  if (searching) {
    std::lock_guard map_lock(map_.mutex);
    if (!keyframe->bad) {
      consistent = loop::consistent_candidates(loop::loop_candidates(map_, keyframe, scores), impl_->groups);
    }
  }
  times.detect_ns = elapsed_ns(start);

  bool closed = false;
  for (KeyFrame* candidate : consistent) {
    const auto verify_start = Clock::now();
    std::vector<int> from_query, from_candidate;
    {
      std::lock_guard map_lock(map_.mutex);
      if (keyframe->bad || candidate->bad) continue;
      from_query = loop::features_with_points(*keyframe);
      from_candidate = loop::features_with_points(*candidate);
    }
    std::vector<FeatureMatch> matches = loop::match_loop_features(*keyframe, from_query, *candidate, from_candidate);
    std::unique_lock map_lock(map_.mutex);
    if (keyframe->bad || candidate->bad) continue;
    loop::LoopMatch match;
    LoopEvent event;
    event.keyframe = keyframe->id;
    event.loop_keyframe = candidate->id;
    event.frame = keyframe->frame_id;
    event.loop_frame = candidate->frame_id;
    const bool verified = loop::verify_loop(keyframe, candidate, std::move(matches), settings_, impl_->pyramid, match);
    event.matches = match.matches;
    event.ransac_inliers = match.ransac_inliers;
    event.inliers = match.inliers;
    event.rejected = match.rejected;
    event.verify_ns = elapsed_ns(verify_start);
    times.verify_ns += event.verify_ns;
    if (verified) {
      global_ba_stop_ = true;  // a running global BA is now out of date (its merge also checks)
      const auto correct_start = Clock::now();
      event.correction_m = loop::correct_loop(map_, keyframe, candidate, match, settings_, impl_->pyramid);
      event.correct_ns = elapsed_ns(correct_start);
      times.correct_ns = event.correct_ns;
      event.closed = true;
      impl_->groups.clear();
      impl_->last_loop_keyframe = keyframe->id;
      impl_->any_loop = true;
      closed = true;
      ++closed_count_;
    }
    map_lock.unlock();
    loops_.push_back(event);
    if (closed) break;
  }
  times_.push_back(times);
  if (!closed || !settings_.global_bundle_adjustment) return;

  // The previous global BA (stopped above) ends before the next one starts.
  if (global_ba_thread_.joinable()) global_ba_thread_.join();
  global_ba_stop_ = false;
  std::uint64_t generation = 0;
  {
    std::lock_guard map_lock(map_.mutex);
    generation = map_.correction_generation;
  }
  if (thread_.joinable()) {
    global_ba_running_ = true;
    global_ba_thread_ = std::thread(&LoopCloser::run_global_ba, this, keyframe->id, generation);
  } else {
    run_global_ba(keyframe->id, generation);
  }
}

void LoopCloser::run_global_ba(std::uint64_t loop_keyframe, std::uint64_t generation) {
  if (thread_.joinable()) cpu::name_this_thread("porta-global-ba");
  const auto start = Clock::now();
  GlobalBaRun run;
  run.after_loop_keyframe = loop_keyframe;
  mapping::BaProblem problem;
  {
    std::lock_guard map_lock(map_.mutex);
    if (map_.correction_generation == generation) problem = loop::collect_global_bundle_adjustment(map_, impl_->pyramid);
  }
  run.keyframes = problem.keyframes.size();
  run.points = problem.points.size();
  if (!problem.observations.empty()) {
    const optim::LocalBundleAdjustmentResult result =
        loop::solve_global_bundle_adjustment(settings_, problem, &global_ba_stop_);
    run.iterations = result.iterations;
    std::lock_guard map_lock(map_.mutex);
    // Another loop moved the map meanwhile: this result belongs to the map before it.
    if (!result.stopped && !global_ba_stop_ && map_.correction_generation == generation) {
      loop::merge_global_bundle_adjustment(map_, problem, result, impl_->pyramid);
      run.applied = true;
    }
  }
  run.time_ns = elapsed_ns(start);
  std::lock_guard lock(queue_mutex_);
  global_ba_runs_.push_back(run);
  global_ba_running_ = false;
}

}  // namespace porta::slam
