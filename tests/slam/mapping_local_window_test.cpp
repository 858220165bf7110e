// Local BA through the map (slam/mapping/local_window.cpp): a point is moved no farther than ten
// times the farthest stereo depth from its reference keyframe; beyond, it keeps its place.
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

}  // namespace
}  // namespace porta::slam::mapping_test
#endif  // PORTA_SLAM_BUILT
