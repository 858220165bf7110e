// The steps of loop closing (loop_closer.hpp), one function each. Private to slam/loop/.
//
// Locking: every function expects the caller to hold Map::mutex, except run_global_bundle_adjustment
// and merge_global_bundle_adjustment, which say what they need. Determinism: loops run over
// feature indices or id-ordered containers.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "../mapping/mapping_steps.hpp"
#include "porta/slam/feature_matching.hpp"
#include "porta/slam/frame.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/place_recognition.hpp"
#include "porta/slam/pose.hpp"
#include "porta/slam/slam_settings.hpp"

namespace porta::slam::loop {

/// ORB-SLAM2's thresholds.
inline constexpr int kMinKeyframesBetweenLoops = 10;  ///< no detection for 10 keyframes after a loop
inline constexpr int kConsistencyThreshold = 3;       ///< consecutive consistent detections
inline constexpr int kMinMatches = 20;                ///< descriptor matches to try RANSAC
inline constexpr int kMinRansacInliers = 20;
inline constexpr int kMinLoopInliers = 40;            ///< after the guided search
inline constexpr int kEssentialCovisibility = 100;    ///< covisibility edges in the essential graph

/// A group of keyframes (a candidate and its covisible neighbours) and how many consecutive
/// queries found a group overlapping it.
struct ConsistentGroup {
  std::vector<std::uint64_t> keyframes;  ///< sorted ids
  int consistency = 0;
};

/// ORB-SLAM2's DetectLoopCandidates on the database scores of `keyframe`'s descriptors (which must
/// not be in the database yet). Best group representative first.
std::vector<KeyFrame*> loop_candidates(const Map& map, KeyFrame* keyframe, const std::vector<PlaceScore>& scores);

/// ORB-SLAM2's DetectRelocalizationCandidates on a frame's scores.
std::vector<KeyFrame*> relocalisation_candidates(const Map& map, const std::vector<PlaceScore>& scores);

/// ORB-SLAM2's consistency test: `groups` holds the groups of the previous query and is replaced by
/// this query's. Returns the candidates whose group reached kConsistencyThreshold.
std::vector<KeyFrame*> consistent_candidates(const std::vector<KeyFrame*>& candidates,
                                             std::vector<ConsistentGroup>& groups);

/// What verification found for one candidate.
struct LoopMatch {
  SE3 T_qw = SE3::Identity();        ///< the query keyframe's pose in the loop keyframe's map
  std::vector<MapPoint*> matched;    ///< per feature of the query keyframe: the loop's point or null
  std::vector<MapPoint*> loop_points;  ///< points of the loop keyframe and its covisibles
  int matches = 0, ransac_inliers = 0, inliers = 0;
  std::string rejected;  ///< empty when verified
};

/// The features of `keyframe` that see a good map point (caller holds the map's lock).
std::vector<int> features_with_points(const KeyFrame& keyframe);

/// The descriptor matches verify_loop starts from, between the features `from_query` of the query
/// keyframe and `from_candidate` of the candidate (features_with_points of each). Reads only the
/// keyframes' immutable features: the caller need not hold the map's lock.
std::vector<FeatureMatch> match_loop_features(const KeyFrame& query, const std::vector<int>& from_query,
                                              const KeyFrame& candidate, const std::vector<int>& from_candidate);

/// From `matches` (match_loop_features; those whose points went bad meanwhile are dropped): RANSAC
/// over the 3-D pairs (SE(3)), the loop group's points projected with the estimate, and the query
/// keyframe's pose optimised against them. True when at least kMinLoopInliers remain. Caller holds
/// the map's lock.
bool verify_loop(KeyFrame* query, KeyFrame* candidate, std::vector<FeatureMatch> matches,
                 const SlamSettings& settings, const ScalePyramid& pyramid, LoopMatch& out);

/// Applies a verified loop: corrects the query's covisible group, fuses the loop's points,
/// optimises the essential graph with `candidate` fixed, moves every point with its reference and
/// links the two keyframes. Increments map.correction_generation. Returns how far the query
/// keyframe moved (metres).
double correct_loop(Map& map, KeyFrame* query, KeyFrame* candidate, const LoopMatch& match,
                    const SlamSettings& settings, const ScalePyramid& pyramid);

/// Global bundle adjustment, in three parts so that the long one runs without the lock.
/// Caller holds the lock: every good keyframe (keyframe 0 fixed) and point.
mapping::BaProblem collect_global_bundle_adjustment(const Map& map, const ScalePyramid& pyramid);
/// No lock needed (works on the copy): up to 30 iterations with the Huber loss, sparse Schur, stopped by
/// `stop`. ORB-SLAM2 removes no outliers here; neither does this.
optim::LocalBundleAdjustmentResult solve_global_bundle_adjustment(const SlamSettings& settings,
                                                                  const mapping::BaProblem& problem,
                                                                  const std::atomic<bool>* stop);
/// Caller holds the lock: writes the result back. Keyframes made meanwhile follow their
/// spanning-tree parent (else the closest older keyframe), points made meanwhile their reference
/// keyframe. Increments map.correction_generation.
void merge_global_bundle_adjustment(Map& map, const mapping::BaProblem& problem,
                                    const optim::LocalBundleAdjustmentResult& result, const ScalePyramid& pyramid);

}  // namespace porta::slam::loop
