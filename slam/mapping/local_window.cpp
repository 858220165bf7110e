// Local mapping steps 5 and 6: local bundle adjustment (after ORB-SLAM2's
// Optimizer::LocalBundleAdjustment, on optim::local_bundle_adjustment) and keyframe culling
// (after ORB-SLAM2's KeyFrameCulling); see mapping_steps.hpp.
#include <algorithm>
#include <atomic>
#include <mutex>
#include <set>
#include <utility>

#include "mapping_steps.hpp"
#include "porta/slam/optim/local_bundle_adjustment.hpp"

namespace porta::slam::mapping {
namespace {

BaProblem collect_local_window(KeyFrame* keyframe, const ScalePyramid& pyramid) {
  std::set<KeyFrame*, ById> local{keyframe};
  for (const auto& [neighbour, weight] : keyframe->connections) {
    if (!neighbour->bad) local.insert(neighbour);
  }
  return collect_bundle_adjustment(local, pyramid);
}

/// Keyframes newer than the adjusted one wait for local mapping (or were made while it adjusted):
/// tracking placed them, and the points they brought, against the map of before the adjustment,
/// and none is in it. They follow the adjusted keyframe's correction, as the frames tracked
/// against it do, so that tracking's next frame meets one map, not the adjusted window beside
/// keyframes and points where they were before (a frame tracked against both lands between them).
/// `adjusted_points` (id order) were adjusted themselves and stay.
void carry_queued_keyframes(Map& map, const KeyFrame& adjusted, const SE3& T_cw_before,
                            const std::vector<MapPoint*>& adjusted_points, const ScalePyramid& pyramid) {
  const SE3 correction = adjusted.T_cw.inverse() * T_cw_before;  // the world before -> after
  const SE3 undo = correction.inverse();
  std::vector<MapPoint*> moved;
  for (std::uint64_t id = adjusted.id + 1;; ++id) {
    KeyFrame* queued = map.keyframe_by_id(id);
    if (queued == nullptr) break;
    if (queued->bad) continue;
    queued->T_cw = queued->T_cw * undo;
    for (MapPoint* point : queued->points) {
      if (point == nullptr || point->bad || point->reference != queued) continue;
      if (std::binary_search(adjusted_points.begin(), adjusted_points.end(), point, ById{})) continue;
      point->position = correction * point->position;
      moved.push_back(point);
    }
  }
  for (MapPoint* point : moved) point->update_normal_and_depth(pyramid);
}

}  // namespace

std::uint64_t new_pass_mark() {
  static std::atomic<std::uint64_t> marks{0};
  return marks.fetch_add(1, std::memory_order_relaxed) + 1;
}

BaProblem collect_bundle_adjustment(const std::set<KeyFrame*, ById>& local, const ScalePyramid& pyramid) {
  // Membership by marks on the map objects (every caller holds Map::mutex), not by trees: this
  // runs under the lock tracking waits for, over thousands of points and their observations.
  const std::uint64_t mark = new_pass_mark();
  BaProblem problem;
  for (KeyFrame* kf : local) {  // id order
    kf->collect_mark = mark;
    kf->collect_index = problem.keyframes.size();
    problem.keyframes.push_back(kf);
    problem.ba_keyframes.push_back({kf->T_cw, kf->id == 0});  // keyframe 0 anchors the map
  }
  std::vector<std::pair<std::uint64_t, MapPoint*>> by_id;
  for (KeyFrame* kf : local) {
    for (MapPoint* point : kf->points) {
      if (point == nullptr || point->bad || point->collect_mark == mark) continue;
      point->collect_mark = mark;
      by_id.emplace_back(point->id, point);
    }
  }
  std::sort(by_id.begin(), by_id.end());
  std::vector<MapPoint*> points(by_id.size());
  for (std::size_t i = 0; i < by_id.size(); ++i) points[i] = by_id[i].second;
  std::vector<KeyFrame*> fixed;
  for (MapPoint* point : points) {
    for (const auto& [observer, feature] : point->observations) {
      if (observer->bad || observer->collect_mark == mark) continue;
      observer->collect_mark = mark;
      fixed.push_back(observer);
    }
  }
  std::sort(fixed.begin(), fixed.end(), ById{});
  for (KeyFrame* kf : fixed) {
    kf->collect_index = problem.keyframes.size();
    problem.keyframes.push_back(kf);
    problem.ba_keyframes.push_back({kf->T_cw, true});
  }
  // Without any fixed keyframe the gauge would be free: hold the oldest local keyframe instead.
  bool any_fixed = false;
  for (const optim::BaKeyframe& kf : problem.ba_keyframes) any_fixed = any_fixed || kf.fixed;
  if (!any_fixed && !problem.ba_keyframes.empty()) problem.ba_keyframes.front().fixed = true;

  for (MapPoint* point : points) {
    const std::size_t point_index = problem.points.size();
    problem.points.push_back(point);
    problem.positions.push_back(point->position);
    for (const auto& [observer, feature] : point->observations) {
      if (observer->bad || observer->collect_mark != mark) continue;
      const FrameFeatures& f = *observer->features;
      const auto s = static_cast<std::size_t>(feature);
      optim::BaObservation observation;
      observation.keyframe = observer->collect_index;
      observation.point = point_index;
      observation.u_left = f.uv[s].x();
      observation.v = f.uv[s].y();
      observation.u_right = f.has_depth(s) ? static_cast<double>(f.u_right[s]) : -1.0;
      observation.sigma2 = pyramid.sigma2[f.level[s]];
      problem.observations.push_back(observation);
      problem.observation_feature.push_back(feature);
    }
  }
  return problem;
}

LocalBundleAdjustmentOutcome local_bundle_adjustment(
    Map& map, KeyFrame* keyframe, const SlamSettings& settings, const ScalePyramid& pyramid,
    const std::atomic<bool>* stop_flag, const std::function<void()>& between_iterations,
    cpu::ThreadPool* pool, double function_tolerance, int steps) {
  BaProblem problem;
  std::uint64_t generation = 0;
  {
    std::lock_guard lock(map.mutex);
    if (keyframe->bad) return {};
    problem = collect_local_window(keyframe, pyramid);
    generation = map.correction_generation;
  }
  if (problem.points.empty() || problem.observations.empty()) return {};

  optim::LocalBundleAdjustmentOptions options;
  options.stop_flag = stop_flag;
  options.function_tolerance = function_tolerance;
  if (steps > 0) {
    options.first_iterations = steps;
    options.second_iterations = 0;  // the outlier test still runs, on the one stage's result
  }
  if (pool != nullptr && pool->size() > 1) {
    options.parallel_for = [pool](std::int64_t n, const std::function<void(std::int64_t)>& fn) {
      pool->parallel_for(0, n, fn);
    };
  }
  options.between_iterations = between_iterations;
  const optim::LocalBundleAdjustmentResult result = optim::local_bundle_adjustment(
      settings.camera, problem.ba_keyframes, problem.positions, problem.observations, options);

  std::lock_guard lock(map.mutex);
  // A loop correction moved the map meanwhile: this window's result is relative to the old map.
  LocalBundleAdjustmentOutcome outcome;
  outcome.iterations = result.iterations;
  if (map.correction_generation != generation) return outcome;
  for (const std::size_t o : result.outlier_observations) {
    MapPoint* point = problem.points[problem.observations[o].point];
    KeyFrame* observer = problem.keyframes[problem.observations[o].keyframe];
    if (point->bad || observer->bad) continue;
    const auto it = point->observations.find(observer);
    if (it == point->observations.end() || it->second != problem.observation_feature[o]) continue;
    Map::erase_observation(point, observer);
    ++outcome.erased;
  }
  const SE3 T_cw_before = keyframe->T_cw;
  for (std::size_t k = 0; k < problem.keyframes.size(); ++k) {
    if (!problem.ba_keyframes[k].fixed && !problem.keyframes[k]->bad)
      problem.keyframes[k]->T_cw = result.T_cw[k];
  }
  // A point is not moved beyond ten times the farthest depth a stereo match gives (bf /
  // min_disparity_px: 771 m on KITTI) from its reference keyframe: no observation constrains its
  // depth there, and nearly parallel rays let the adjustment run it off along them (to 23 km on the
  // street loop's first 20 frames). It keeps its place, where its rays still constrain rotation.
  // (Twice that bound also held points that relocalisation needed: tests/cli/covered_lens.cmake.)
  const double far_m = 10.0 * settings.camera.bf() / settings.min_disparity_px;
  for (std::size_t p = 0; p < problem.points.size(); ++p) {
    MapPoint* point = problem.points[p];
    if (point->bad) continue;
    if (point->reference != nullptr && (result.points[p] - point->reference->center()).norm() > far_m) continue;
    point->position = result.points[p];
    point->update_normal_and_depth(pyramid);
  }
  // Only after a whole adjustment (the two stages): a single step (steps > 0, right after the
  // keyframe before's) moves the window part of the way and the next keyframe's step goes on, and
  // carrying each partial step onto the queued keyframes compounded: with a step on every
  // keyframe (--ba-every 1) as fast as possible on an H100, tracking was lost for good within 330
  // frames in three runs of three.
  if (settings.queued_keyframes_follow_ba && steps == 0 && !keyframe->bad)
    carry_queued_keyframes(map, *keyframe, T_cw_before, problem.points, pyramid);
  return outcome;
}

int cull_redundant_keyframes(KeyFrame* keyframe, double close_depth_m) {
  constexpr int kObserversNeeded = 3;
  int culled = 0;
  // By decreasing weight, as ORB-SLAM2: the copy stays valid while culling rewrites the edges.
  for (KeyFrame* candidate : keyframe->covisibles_with_weight(0)) {
    if (candidate->id == 0 || candidate->bad) continue;
    const FrameFeatures& f = *candidate->features;
    int counted = 0, redundant = 0;
    for (std::size_t i = 0; i < candidate->points.size(); ++i) {
      const MapPoint* point = candidate->points[i];
      if (point == nullptr || point->bad) continue;
      // Stereo: only close points, whose depth the keyframe measured reliably, count.
      if (!f.has_depth(i) || f.depth_m[i] > close_depth_m) continue;
      ++counted;
      if (point->num_observations() <= kObserversNeeded) continue;
      const int level = f.level[i];
      int observers = 0;
      for (const auto& [observer, feature] : point->observations) {
        if (observer == candidate) continue;
        // Seen at the same or a finer scale (one level of slack, as ORB-SLAM2).
        if (observer->features->level[static_cast<std::size_t>(feature)] <= level + 1 &&
            ++observers >= kObserversNeeded) {
          break;
        }
      }
      if (observers >= kObserversNeeded) ++redundant;
    }
    if (counted > 0 && redundant > 0.9 * counted && candidate->loop_edges.empty()) {
      Map::set_bad(candidate);
      ++culled;
    }
  }
  return culled;
}

}  // namespace porta::slam::mapping
