// The steps of local mapping (local_mapper.hpp), one function each so that every step can be read,
// timed and tested on its own. Private to slam/mapping/.
//
// Locking: functions taking `Map&` lock Map::mutex themselves (they hold it only for short
// read-modify sections and do the long work on copies); the others expect the caller to hold it.
// Determinism: every loop runs over feature indices or id-ordered containers.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <set>
#include <vector>

#include "cpu/thread_pool.hpp"
#include "porta/slam/frame.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/optim/local_bundle_adjustment.hpp"
#include "porta/slam/slam_settings.hpp"

namespace porta::slam::mapping {

/// ORB-SLAM2's ORBmatcher thresholds.
inline constexpr int kHammingLow = 50;      ///< TH_LOW: best distance accepted
inline constexpr double kMatchRatio = 0.6;  ///< best < ratio * second best
inline constexpr int kRotationBins = 30;    ///< rotation-consistency histogram over 360 degrees

/// Covisible keyframes used for triangulation and fusion (ORB-SLAM2's stereo setting: 10).
inline constexpr std::size_t kNeighbours = 10;
/// A recent point two keyframes old with at most this many observations (stereo ones counting
/// twice) is culled: ORB-SLAM2's cnThObs for stereo, compared with <= as ORB-SLAM2 does.
inline constexpr int kMaxRecentObservationsToCull = 3;

/// Hamming distance of two descriptors (porta::slam::hamming_distance), inline: it is the inner loop
/// of triangulation's epipolar search and of fusion (an out-of-line call was 1.6 % of the samples).
inline int descriptor_distance(const Descriptor& a, const Descriptor& b) { return hamming_distance(a, b); }

/// Step 1 (caller holds `lock` on Map::mutex): makes sure every point tracking matched (following
/// merges) is observed by `keyframe`, refreshes the points' normals, depth ranges and descriptors,
/// and updates the keyframe's covisibility edges. Between chunks of points it hands the lock to a
/// waiting tracker (Map::yield_to_waiters). With a `pool` of more than one thread the refreshes run
/// on it (the same values) and the chunks are larger. Returns the points `keyframe` created
/// (first_keyframe_id == keyframe->id), which the recent-point culling watches.
std::vector<MapPoint*> link_keyframe_points(Map& map, std::unique_lock<MapMutex>& lock, KeyFrame* keyframe,
                                            const ScalePyramid& pyramid, cpu::ThreadPool* pool = nullptr);

/// Step 2 (caller holds the lock): ORB-SLAM2's MapPointCulling over `recent` as of keyframe
/// `current_keyframe_id`; culled points go bad, points old enough leave the list. Returns the
/// number culled.
int cull_recent_points(std::vector<MapPoint*>& recent, std::uint64_t current_keyframe_id);

/// Step 3 (locks the map itself): creates points from matches between the keyframe's unmatched
/// features and those of its best covisible keyframes; appends them to `recent`. `should_stop` is
/// asked before every neighbour but the first (more keyframes waiting); `first_neighbour_only`
/// says it already holds (keyframes wait). With a `pool` of more than one thread, the epipolar
/// searches of the neighbours run first, in parallel (only the first's when
/// `first_neighbour_only`); the points are the same. Returns the count created.
int triangulate_new_points(Map& map, KeyFrame* keyframe, const SlamSettings& settings,
                           const ScalePyramid& pyramid, std::vector<MapPoint*>& recent,
                           const std::function<bool()>& should_stop, bool first_neighbour_only = false,
                           cpu::ThreadPool* pool = nullptr);

/// Step 4 (`lock` holds Map::mutex): ORB-SLAM2's SearchInNeighbors. Between target keyframes it
/// hands the lock to a waiting tracker (Map::yield_to_waiters), as ORB-SLAM2's per-object locks
/// let tracking run beside it. With a `pool` of more than one thread the searches and the points'
/// refreshes run on it (the same map). Returns the number of points merged into another
/// (Map::replace).
int fuse_with_neighbours(Map& map, std::unique_lock<MapMutex>& lock, KeyFrame* keyframe,
                         const SlamSettings& settings, const ScalePyramid& pyramid, cpu::ThreadPool* pool = nullptr);

/// Projects `points` into `keyframe` and fuses each with the best-matching feature in a window of
/// radius_factor * scale of its predicted level (ORB-SLAM2's ORBmatcher::Fuse). Caller holds the
/// lock. Returns the number of points merged (Map::replace); `added`, when given, counts the
/// observations added to features without a point. With a `pool` of more than one thread the
/// points' searches run on it first (fusion.cpp says why the result is the same).
int fuse_points_into(KeyFrame* keyframe, const std::vector<MapPoint*>& points, const StereoCamera& camera,
                     const ScalePyramid& pyramid, double radius_factor = 3.0, int* added = nullptr,
                     cpu::ThreadPool* pool = nullptr);

/// Step 5 (locks the map itself): local bundle adjustment around `keyframe`; keyframe 0 is never
/// moved. With a `pool` of more than one thread the solver's loops run on it (the same result).
/// `function_tolerance`: LocalBundleAdjustmentOptions::function_tolerance. `steps` > 0: one stage of
/// at most that many iterations with the robust loss, then the outlier test (no second stage; see
/// SlamSettings::realtime_bundle_adjustment_steps); 0: ORB-SLAM2's two stages.
struct LocalBundleAdjustmentOutcome {
  int erased = 0;      ///< outlier observations erased from the map
  int iterations = 0;  ///< Levenberg-Marquardt iterations of both stages
};
LocalBundleAdjustmentOutcome local_bundle_adjustment(
    Map& map, KeyFrame* keyframe, const SlamSettings& settings, const ScalePyramid& pyramid,
    const std::atomic<bool>* stop_flag, const std::function<void()>& between_iterations = {},
    cpu::ThreadPool* pool = nullptr,
    double function_tolerance = SlamSettings::kDeterministicBundleAdjustmentTolerance, int steps = 0);

/// A bundle adjustment copied out of the map under the lock, with the map objects each entry
/// stands for (local and global bundle adjustment).
struct BaProblem {
  std::vector<KeyFrame*> keyframes;  // free ones first, then fixed ones; each in id order
  std::vector<MapPoint*> points;     // id order
  std::vector<optim::BaKeyframe> ba_keyframes;
  std::vector<Eigen::Vector3d> positions;
  std::vector<optim::BaObservation> observations;
  std::vector<int> observation_feature;  // per observation: the keyframe's feature index
};

/// A mark no pass over map objects has used yet, for membership tests by `collect_mark` (instead of
/// a set per pass) in a pass that holds Map::mutex throughout.
std::uint64_t new_pass_mark();

/// Caller holds the lock: `free` keyframes, every good point they see, and the other keyframes
/// observing those points as fixed ones; keyframe 0 is always fixed (without any fixed keyframe
/// the oldest free one is held, to fix the gauge).
BaProblem collect_bundle_adjustment(const std::set<KeyFrame*, ById>& free, const ScalePyramid& pyramid);

/// Step 6 (caller holds the lock): culls the covisible keyframes of `keyframe` whose close points
/// are at least 90% seen by 3 other keyframes at the same or a finer scale. Returns the count.
int cull_redundant_keyframes(KeyFrame* keyframe, double close_depth_m);

}  // namespace porta::slam::mapping
