// Local bundle adjustment on a thread of its own (SlamSettings::bundle_adjustment_thread, the
// realtime mode): the same map as the deterministic mode when each keyframe is mapped and adjusted
// before the next arrives; with keyframes queued, the newest processed keyframe's window each
// time, the last one's at stop(); beside tracking and the mapping thread (run under TSan in CI).
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <chrono>
#include <thread>
#include <vector>

#include "mapping_scene.hpp"
#include "porta/slam/tracker.hpp"
#include "synthetic_world.hpp"

namespace porta::slam::mapping_test {
namespace {

/// Until the mapping thread is idle with nothing queued and the BA thread has adjusted what it got.
void wait_until_mapped_and_adjusted(const LocalMapper& mapper) {
  while (mapper.queued_keyframes() > 0 || !mapper.accepts_keyframes() || mapper.bundle_adjustment_pending()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

SlamSettings with_ba_thread(SlamSettings settings) {
  settings.bundle_adjustment_thread = true;
  return settings;
}

TEST(Mapping, BundleAdjustmentThreadFedOneAtATimeGivesTheDeterministicMap) {
  // As RealtimeModeFedOneAtATimeGivesTheDeterministicMap: each keyframe mapped, then its window
  // adjusted (the deterministic two stages) and the keyframes around it culled, before the next.
  const SyntheticScene scene{SceneSpec{}};
  Map deterministic_map;
  LocalMapper deterministic(test_settings(), deterministic_map);
  {
    TrackingStandIn tracking(scene, deterministic_map, deterministic);
    for (std::size_t k = 0; k < scene.true_T_cw.size(); ++k) {
      tracking.insert(k, scene.true_T_cw[k]);
      deterministic.process_all();
    }
  }

  SlamSettings settings = with_ba_thread(test_settings());
  settings.realtime_bundle_adjustment_tolerance = SlamSettings::kDeterministicBundleAdjustmentTolerance;
  settings.realtime_bundle_adjustment_steps = 0;
  Map map;
  LocalMapper mapper(settings, map);
  TrackingStandIn tracking(scene, map, mapper);
  mapper.start();
  for (std::size_t k = 0; k < scene.true_T_cw.size(); ++k) {
    tracking.insert(k, scene.true_T_cw[k]);
    wait_until_mapped_and_adjusted(mapper);
  }
  mapper.stop();
  ASSERT_EQ(mapper.times().size(), deterministic.times().size());
  for (std::size_t k = 0; k < mapper.times().size(); ++k) {
    EXPECT_EQ(mapper.times()[k].bundle_adjustment_ran, deterministic.times()[k].bundle_adjustment_ran) << k;
    EXPECT_EQ(mapper.times()[k].bundle_adjustment_iterations, deterministic.times()[k].bundle_adjustment_iterations)
        << k;
  }
  EXPECT_EQ(mapper.bundle_adjustment_runs().size(), scene.true_T_cw.size() - 2) << "every keyframe from the third";
  EXPECT_EQ(mapper.keyframes_culled(), deterministic.keyframes_culled());
  EXPECT_TRUE(MapSnapshot(map) == MapSnapshot(deterministic_map));
}

// Keyframes queued together: the mapping thread goes through them without waiting for an
// adjustment; the BA thread takes the newest it was handed each time, so its windows go forward,
// and the last keyframe's window is adjusted before stop() returns.
TEST(Mapping, BundleAdjustmentThreadTakesTheNewestKeyframeAndTheLastBeforeStopping) {
  SceneSpec spec;
  spec.keyframes = 9;
  spec.step_m = 0.15;
  const SyntheticScene scene{spec};
  ASSERT_EQ(scene.true_T_cw.size(), 9u);
  Map map;
  LocalMapper mapper(with_ba_thread(test_settings()), map);
  TrackingStandIn tracking(scene, map, mapper);
  mapper.start();
  for (std::size_t k = 0; k < 3; ++k) {
    tracking.insert(k, scene.true_T_cw[k]);
    wait_until_mapped_and_adjusted(mapper);
  }
  for (std::size_t k = 3; k < 9; ++k) tracking.insert(k, scene.true_T_cw[k]);
  mapper.stop();
  ASSERT_EQ(mapper.times().size(), 9u);
  const std::vector<BundleAdjustmentRun>& runs = mapper.bundle_adjustment_runs();
  ASSERT_GE(runs.size(), 2u);
  EXPECT_EQ(runs.front().keyframe_id, 2u) << "the first window with three keyframes";
  EXPECT_FALSE(runs.front().continued) << "the first window: both stages";
  for (std::size_t r = 1; r < runs.size(); ++r) {
    EXPECT_GT(runs[r].keyframe_id, runs[r - 1].keyframe_id) << "run " << r;
  }
  EXPECT_EQ(runs.back().keyframe_id, 8u) << "the last keyframe's window, before stop() returned";
  EXPECT_TRUE(mapper.times()[8].bundle_adjustment_ran);
  // Nothing went wrong on the way: the poses stay on the truth they were placed at.
  std::lock_guard lock(map.mutex);
  for (const KeyFrame* keyframe : map.keyframes()) {
    const SE3& truth = scene.true_T_cw[keyframe->frame_id];
    EXPECT_LT((keyframe->T_cw.inverse().translation() - truth.inverse().translation()).norm(), 0.01)
        << "keyframe " << keyframe->id;
  }
}

// Tracking, the mapping thread and the BA thread together, as `portaslam run --ba-thread on`.
TEST(Mapping, BundleAdjustmentThreadBesideTrackingAndMappingTracksWithinCentimetres) {
  constexpr int kFrames = 30;
  const test::World w(test::straight_path(kFrames + 10), 33, 1200, kFrames);
  test::Pipeline p(w, with_ba_thread(w.settings));
  p.mapper.start();
  std::vector<TrackingResult> results;
  for (int k = 0; k < kFrames; ++k) {
    results.push_back(p.tracker.track(static_cast<std::uint64_t>(k), 0.1 * k, test::observe(w, k, 33)));
  }
  p.mapper.stop();
  for (int k = 0; k < kFrames; ++k) {
    const TrackingResult& r = results[static_cast<std::size_t>(k)];
    ASSERT_EQ(r.state, TrackingState::ok) << "frame " << k << ": " << r.lost_reason;
    const SE3& truth = w.T_cw[static_cast<std::size_t>(k)];
    EXPECT_LT((r.T_cw.inverse().translation() - truth.inverse().translation()).norm(), 0.05) << "frame " << k;
  }
  EXPECT_GE(p.mapper.bundle_adjustment_runs().size(), 1u);
}

}  // namespace
}  // namespace porta::slam::mapping_test
#endif  // PORTA_SLAM_BUILT
