// LocalMapper: the keyframe queue, the realtime thread and the order of the steps
// (mapping_steps.hpp); see local_mapper.hpp.
//
// Threads: the queue has its own mutex (never held while taking Map::mutex, so tracking may insert
// a keyframe while it holds the map). The steps take Map::mutex themselves; bundle adjustment
// computes without it. Fusion, bundle adjustment and keyframe culling are skipped while more
// keyframes wait, as ORB-SLAM2 does, so a mapper that falls behind catches up; in the
// deterministic mode the queue holds what the caller inserted, so that choice is reproducible too.
#include "porta/slam/local_mapper.hpp"

#include <chrono>
#include <stdexcept>

#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#endif

#include "cpu/thread_name.hpp"
#include "cpu/thread_pool.hpp"
#include "mapping_steps.hpp"
#include "../system/thread_niceness.hpp"
#include "porta/slam/elapsed.hpp"

namespace porta::slam {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

LocalMapper::LocalMapper(const SlamSettings& settings, Map& map)
    : settings_(settings), pyramid_(settings.frontend.levels, settings.frontend.scale_factor), map_(map) {
  if (const int threads = settings_.resolved_mapping_threads(); threads > 1) {
    pool_ = std::make_unique<cpu::ThreadPool>(threads, "porta-map-pool");
  }
}

LocalMapper::~LocalMapper() { stop(); }

void LocalMapper::insert_keyframe(KeyFrame* keyframe) {
  if (keyframe == nullptr) throw std::invalid_argument("LocalMapper::insert_keyframe: keyframe is null");
  {
    std::lock_guard lock(queue_mutex_);
    queue_.push_back(keyframe);
    abort_ba_ = true;  // a running bundle adjustment yields to the new keyframe
    const auto now = Clock::now().time_since_epoch().count();
    if (last_insert_ns_ != 0) keyframe_interval_ns_ = now - last_insert_ns_;
    last_insert_ns_ = now;
  }
  queue_cv_.notify_one();
}

bool LocalMapper::accepts_keyframes() const { return idle_; }

std::size_t LocalMapper::queued_keyframes() const {
  std::lock_guard lock(queue_mutex_);
  return queue_.size();
}

void LocalMapper::wait_while_queued(std::size_t limit) {
  std::unique_lock lock(queue_mutex_);
  dequeued_cv_.wait(lock, [&] { return queue_.size() < limit || stop_requested_ || !realtime_; });
}

void LocalMapper::interrupt_bundle_adjustment() { abort_ba_ = true; }

KeyFrame* LocalMapper::pop_keyframe() {
  std::lock_guard lock(queue_mutex_);
  if (queue_.empty()) return nullptr;
  KeyFrame* keyframe = queue_.front();
  queue_.pop_front();
  abort_ba_ = false;  // only keyframes inserted from now on interrupt this one's adjustment
  return keyframe;
}

void LocalMapper::process_all() {
  if (thread_.joinable()) {
    throw std::logic_error(
        "LocalMapper::process_all: the mapping thread is running (realtime mode); "
        "call stop() first or use insert_keyframe() alone");
  }
  while (KeyFrame* keyframe = pop_keyframe()) process(keyframe);
}

void LocalMapper::start() {
  if (thread_.joinable()) return;
  stop_requested_ = false;
  realtime_ = true;  // before the thread starts, so it reads it without a race
  thread_ = std::thread(&LocalMapper::thread_main, this);
}

void LocalMapper::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard lock(queue_mutex_);
    stop_requested_ = true;
  }
  queue_cv_.notify_all();
  tracking_cv_.notify_all();
  dequeued_cv_.notify_all();
  thread_.join();
  realtime_ = false;
}

void LocalMapper::tracking_started() {
  std::lock_guard lock(queue_mutex_);
  tracking_busy_ = true;
}

void LocalMapper::tracking_finished() {
  {
    std::lock_guard lock(queue_mutex_);
    tracking_busy_ = false;
  }
  tracking_cv_.notify_all();
}

void LocalMapper::pause_point() {
  if (!settings_.mapping_yields_to_tracking) return;
  std::unique_lock lock(queue_mutex_);
  const auto resume = [this] { return !tracking_busy_ || !queue_.empty() || stop_requested_; };
  if (resume()) return;
  const auto since = Clock::now();
  tracking_cv_.wait(lock, resume);
  paused_ns_ += elapsed_ns(since);
}

void LocalMapper::thread_main() {
  cpu::name_this_thread("porta-mapping");
#if defined(__linux__)
  // Tracking's latency comes first. SCHED_IDLE: the mapping thread runs only on a core nothing
  // else wants, and a waking tracking or frontend thread takes the core at once (a nice value
  // still lets it finish its time slice first, milliseconds that a 30 ms frame cannot spare).
  // Best effort: a refusal leaves the thread as it was.
  if (settings_.mapping_thread_idle_priority) {
    sched_param param{};
    param.sched_priority = 0;
    (void)pthread_setschedparam(pthread_self(), SCHED_IDLE, &param);
  } else {
    detail::set_thread_nice(settings_.mapping_thread_nice);
  }
#endif
  for (;;) {
    KeyFrame* keyframe = nullptr;
    {
      std::unique_lock lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return !queue_.empty() || stop_requested_; });
      if (queue_.empty()) break;  // stop requested and the queue drained
      keyframe = queue_.front();
      queue_.pop_front();
      abort_ba_ = false;
      idle_ = false;  // under the queue lock: "nothing queued and idle" means all processed
    }
    dequeued_cv_.notify_all();
    process(keyframe);
    std::lock_guard lock(queue_mutex_);
    idle_ = true;
  }
}

bool LocalMapper::spread_over_pool() const {
  if (pool_ == nullptr) return false;
  if (!realtime_) return true;  // deterministic: the caller waits for mapping
  std::lock_guard lock(queue_mutex_);
  // Realtime: only while keyframes come faster than one thread maps them (as fast as possible);
  // at camera rate one thread keeps up, and the pool's workers would only add CPU time.
  return keyframe_interval_ns_ > 0 && last_mapping_ns_ > keyframe_interval_ns_;
}

void LocalMapper::process(KeyFrame* keyframe) {
  MappingTimes times;
  cpu::ThreadPool* const pool = spread_over_pool() ? pool_.get() : nullptr;
  times.keyframe_id = keyframe->id;
  times.spread = pool != nullptr;
  {
    std::lock_guard lock(queue_mutex_);
    times.queued = queue_.size();
    times.interval_ns = keyframe_interval_ns_;
  }
  const auto start = Clock::now();
  const std::int64_t paused_at_start = paused_ns_;
  const std::int64_t lock_wait_at_start = MapMutex::thread_wait_ns();
  auto step = Clock::now();
  std::int64_t paused_at_step = paused_ns_;
  // Starts a step at a pause point; work_ns() is the step's time without the pauses.
  const auto begin_step = [&] {
    pause_point();
    step = Clock::now();
    paused_at_step = paused_ns_;
  };
  const auto work_ns = [&] { return elapsed_ns(step) - (paused_ns_ - paused_at_step); };

  begin_step();
  {
    std::unique_lock lock(map_.mutex);
    if (!keyframe->bad) {
      const std::vector<MapPoint*> created = mapping::link_keyframe_points(map_, lock, keyframe, pyramid_, pool);
      recent_points_.insert(recent_points_.end(), created.begin(), created.end());
    }
  }
  times.process_ns = work_ns();

  begin_step();
  {
    std::lock_guard lock(map_.mutex);
    points_culled_ += static_cast<std::uint64_t>(mapping::cull_recent_points(recent_points_, keyframe->id));
  }
  times.cull_points_ns = work_ns();

  begin_step();
  points_triangulated_ += static_cast<std::uint64_t>(mapping::triangulate_new_points(
      map_, keyframe, settings_, pyramid_, recent_points_,
      [this] {
        pause_point();
        return queued_keyframes() > 0;
      },
      queued_keyframes() > 0, pool));
  times.triangulate_ns = work_ns();

  if (queued_keyframes() == 0) {
    begin_step();
    {
      std::unique_lock lock(map_.mutex);
      points_fused_ +=
          static_cast<std::uint64_t>(mapping::fuse_with_neighbours(map_, lock, keyframe, settings_, pyramid_, pool));
    }
    times.fuse_ns = work_ns();
  }

  // Local BA when no keyframe waits (ORB-SLAM2), or when it is due (bundle_adjustment_every): then
  // to the end, whatever arrives meanwhile.
  const int every = settings_.bundle_adjustment_every;
  const bool due = every > 0 && keyframes_without_ba_ + 1 >= every;
  if (queued_keyframes() == 0 || due) {
    begin_step();
    bool enough_keyframes = false;
    {
      std::lock_guard lock(map_.mutex);
      enough_keyframes = map_.num_keyframes() > 2;
    }
    if (enough_keyframes) {
      // Realtime, right after the keyframe before had its own: a few steps continue that one's work.
      const int steps = realtime_ && keyframes_without_ba_ == 0 ? settings_.realtime_bundle_adjustment_steps : 0;
      times.bundle_adjustment_iterations =
          mapping::local_bundle_adjustment(map_, keyframe, settings_, pyramid_,
                                           due ? &stop_requested_ : &abort_ba_, [this] { pause_point(); }, pool,
                                           realtime_ ? settings_.realtime_bundle_adjustment_tolerance
                                                     : SlamSettings::kDeterministicBundleAdjustmentTolerance,
                                           steps)
              .iterations;
      times.bundle_adjustment_ran = true;
    }
    times.bundle_adjustment_ns = work_ns();

    begin_step();
    {
      std::lock_guard lock(map_.mutex);
      if (!keyframe->bad) {
        keyframes_culled_ += static_cast<std::uint64_t>(
            mapping::cull_redundant_keyframes(keyframe, settings_.close_depth_m()));
      }
    }
    times.cull_keyframes_ns = work_ns();
  }
  keyframes_without_ba_ = times.bundle_adjustment_ran ? 0 : keyframes_without_ba_ + 1;
  times.total_ns = elapsed_ns(start) - (paused_ns_ - paused_at_start);
  times.lock_wait_ns = MapMutex::thread_wait_ns() - lock_wait_at_start;
  times_.push_back(times);
  {
    std::lock_guard lock(queue_mutex_);
    last_mapping_ns_ = elapsed_ns(start);  // with the pauses: what the next keyframe waits for
  }
  if (keyframe_processed_) keyframe_processed_(keyframe);
}

}  // namespace porta::slam
