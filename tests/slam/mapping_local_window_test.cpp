// Local BA through the map (slam/mapping/local_window.cpp): a point is moved no farther than ten
// times the farthest stereo depth from its reference keyframe; beyond, it keeps its place. A
// keyframe still queued for mapping follows the adjusted keyframe's correction with its points.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "mapping_scene.hpp"
#include "slam/mapping/mapping_steps.hpp"

namespace porta::slam::mapping_test {
namespace {

TEST(MappingLocalWindow, APointSentBeyondTenStereoDepthsKeepsItsPlace) {
  SceneSpec spec;
  spec.keyframes = 4;
  const SyntheticScene scene(spec);
  Map map;
  const SlamSettings settings = test_settings();
  LocalMapper mapper(settings, map);
  TrackingStandIn tracking(scene, map, mapper);
  KeyFrame* last = nullptr;
  for (std::size_t k = 0; k < scene.true_T_cw.size(); ++k) {
    last = tracking.insert(k, scene.true_T_cw[k]);
    mapper.process_all();
  }

  // The bound at 4.5 m (bf 50 px m, so a farthest stereo depth of 0.45 m): the scene's points lie
  // 1.5 to 7 m away, so the adjustment keeps some and moves the rest. Every point is pushed off
  // its place first, so that the adjustment moves each one it may.
  SlamSettings near_bound = settings;
  near_bound.min_disparity_px = 10.0 * settings.camera.bf() / 4.5;
  const double far_m = 4.5;
  std::map<const MapPoint*, Eigen::Vector3d> before;
  {
    std::lock_guard lock(map.mutex);
    std::mt19937 rng(3);
    std::normal_distribution<double> noise(0.0, 0.03);
    for (MapPoint* p : map.points()) {
      p->position += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      before[p] = p->position;
    }
  }
  const ScalePyramid pyramid(settings.frontend.levels, settings.frontend.scale_factor);
  mapping::local_bundle_adjustment(map, last, near_bound, pyramid, nullptr);

  std::lock_guard lock(map.mutex);
  int held = 0, moved = 0;
  for (const MapPoint* p : map.points()) {
    if (p->bad || p->reference == nullptr) continue;
    const Eigen::Vector3d& old_position = before.at(p);
    if (p->position == old_position) {
      held += (old_position - p->reference->center()).norm() > far_m ? 1 : 0;
      continue;
    }
    ++moved;
    EXPECT_LE((p->position - p->reference->center()).norm(), far_m)
        << "point " << p->id << " was moved beyond the bound";
  }
  std::printf("points held beyond %.1f m: %d, moved within it: %d\n", far_m, held, moved);
  EXPECT_GT(held, 20) << "the far points should keep their place";
  EXPECT_GT(moved, 50) << "the close points should be adjusted";
}

/// Keyframe 4 made as tracking makes one while mapping adjusts keyframe 3's window: its matches in
/// `points` (linked by mapping later), new points from its close stereo features for the rest.
KeyFrame* make_queued_keyframe(Map& map, const SyntheticScene& scene, const TrackingStandIn& tracking,
                               std::size_t k, std::vector<MapPoint*>& made) {
  std::lock_guard lock(map.mutex);
  Frame frame(k, 0.1 * static_cast<double>(k), scene.features[k], kCamera);
  frame.T_cw = scene.true_T_cw[k];
  frame.has_pose = true;
  KeyFrame* keyframe = map.add_keyframe(frame);
  const FrameFeatures& f = *scene.features[k];
  for (std::size_t i = 0; i < f.size(); ++i) {
    const int j = scene.truth[k][i];
    if (j < 0 || !f.has_depth(i) || f.depth_m[i] > test_settings().close_depth_m()) continue;
    if (MapPoint* matched = tracking.resolve(j)) {
      keyframe->points[i] = matched;
      continue;
    }
    MapPoint* point = map.add_point(frame.unproject_stereo(i, kCamera), keyframe, frame.id);
    Map::add_observation(point, keyframe, static_cast<int>(i));
    made.push_back(point);
  }
  return keyframe;
}

TEST(MappingLocalWindow, AQueuedKeyframeFollowsTheAdjustedKeyframesCorrection) {
  SceneSpec spec;
  spec.keyframes = 5;
  spec.private_points = 40;  // close points only keyframe 4 sees: it makes them
  spec.private_keyframe = 4;
  const SyntheticScene scene(spec);
  // On after two stages (carried); off; on after a single step (not carried).
  for (const int mode : {0, 1, 2}) {
    const bool follow = mode != 1;
    const int steps = mode == 2 ? 1 : 0;
    const bool carried = mode == 0;
    SCOPED_TRACE(follow ? (steps == 0 ? "on, two stages" : "on, one step") : "off");
    Map map;
    SlamSettings settings = test_settings();
    settings.queued_keyframes_follow_ba = follow;
    LocalMapper mapper(settings, map);
    TrackingStandIn tracking(scene, map, mapper);
    KeyFrame* adjusted = nullptr;
    for (std::size_t k = 0; k < 4; ++k) {
      adjusted = tracking.insert(k, scene.true_T_cw[k]);
      mapper.process_all();
    }
    std::vector<MapPoint*> made;
    KeyFrame* queued = make_queued_keyframe(map, scene, tracking, 4, made);
    ASSERT_GT(made.size(), 5u) << "keyframe 4 should bring points of its own";

    // Keyframe 3 knocked off its place, so that the adjustment moves it back.
    SE3 knock = SE3::Identity();
    knock.linear() = Eigen::AngleAxisd(0.004, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
    knock.translation() = Eigen::Vector3d(0.03, -0.02, 0.01);
    std::vector<Eigen::Vector3d> made_before;
    SE3 adjusted_before, queued_before;
    {
      std::lock_guard lock(map.mutex);
      adjusted->T_cw = knock * adjusted->T_cw;
      adjusted_before = adjusted->T_cw;
      queued_before = queued->T_cw;
      for (const MapPoint* p : made) made_before.push_back(p->position);
    }
    const ScalePyramid pyramid(settings.frontend.levels, settings.frontend.scale_factor);
    mapping::local_bundle_adjustment(map, adjusted, settings, pyramid, nullptr, {}, nullptr,
                                     SlamSettings::kDeterministicBundleAdjustmentTolerance, steps);

    std::lock_guard lock(map.mutex);
    const SE3 correction = adjusted->T_cw.inverse() * adjusted_before;  // the world before -> after
    ASSERT_GT(correction.translation().norm(), 0.005) << "the adjustment should have moved keyframe 3";
    const SE3 expected = carried ? queued_before * correction.inverse() : queued_before;
    EXPECT_LT((queued->T_cw.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-12);
    for (std::size_t i = 0; i < made.size(); ++i) {
      const Eigen::Vector3d want = carried ? Eigen::Vector3d(correction * made_before[i]) : made_before[i];
      EXPECT_LT((made[i]->position - want).norm(), 1e-12) << "point " << made[i]->id;
    }
  }
}

}  // namespace
}  // namespace porta::slam::mapping_test
#endif  // PORTA_SLAM_BUILT
