// Tracking that lets the map's lock go while it computes on copies of map data
// (Tracker::release_map_lock_while_computing, the realtime mode): the same poses and matches as with
// the lock held for the whole frame, the lock really free in those windows, and what local mapping
// or loop closing may do meanwhile handled: points culled, the whole map moved.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <cstring>
#include <future>
#include <mutex>
#include <numbers>
#include <set>
#include <vector>

#include "porta/slam/map.hpp"
#include "porta/slam/tracker.hpp"
#include "synthetic_world.hpp"

namespace porta::slam {
namespace {

constexpr int kFrames = 30;

/// 0.3 m forward and 1 degree of yaw per frame.
std::vector<SE3> straight_path() { return test::straight_path(kFrames + 10); }

bool same_bits(const SE3& a, const SE3& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 16) == 0;
}

double translation_error_m(const SE3& a, const SE3& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();
}

/// Whether another thread can take `mutex` now (try_lock by its owner is undefined).
bool free_for_another_thread(MapMutex& mutex) {
  return std::async(std::launch::async, [&] {
           if (!mutex.try_lock()) return false;
           mutex.unlock();
           return true;
         }).get();
}

TEST(TrackingMapLock, ReleasedWhileComputingGivesTheSamePosesAndMatchesAsHeld) {
  const test::World w(straight_path(), 21, 1200, kFrames);
  test::Pipeline held(w, w.settings), released(w, w.settings);
  released.tracker.release_map_lock_while_computing(true);
  int windows = 0, free_windows = 0;
  released.tracker.set_unlocked_hook([&] {
    ++windows;
    free_windows += free_for_another_thread(released.map.mutex) ? 1 : 0;
  });
  held.run(w, kFrames, 21);
  released.run(w, kFrames, 21);
  for (int k = 0; k < kFrames; ++k) {
    const auto i = static_cast<std::size_t>(k);
    ASSERT_EQ(released.results[i].state, TrackingState::ok) << released.results[i].lost_reason;
    EXPECT_TRUE(same_bits(held.results[i].T_cw, released.results[i].T_cw)) << "frame " << k;
    EXPECT_EQ(held.matched_ids[i], released.matched_ids[i]) << "frame " << k;
    EXPECT_EQ(held.results[i].keyframe_inserted, released.results[i].keyframe_inserted) << "frame " << k;
    EXPECT_EQ(held.results[i].unlocked_ns, 0) << "frame " << k;
    if (k > 0) {
      EXPECT_GT(released.results[i].unlocked_ns, 0) << "frame " << k;
    }
  }
  // Every tracked frame after the first: the motion model's pose, the local map's matching and pose.
  EXPECT_GE(windows, 3 * (kFrames - 1));
  EXPECT_EQ(free_windows, windows) << "the lock was held in a window meant to be without it";
}

TEST(TrackingMapLock, PointsCulledWhileTheLockIsReleasedAreNotKept) {
  const test::World w(straight_path(), 23, 1200, kFrames);
  test::Pipeline p(w, w.settings);
  p.tracker.release_map_lock_while_computing(true);
  int frame = 0, window = 0;
  std::set<const MapPoint*> culled;
  // On frames 10-14, in the last window (the local map's pose), local mapping culls one in four of
  // the points the last frame matched: most are this frame's matches too.
  p.tracker.set_unlocked_hook([&] {
    if (frame < 10 || frame > 14 || ++window != 3) return;
    std::lock_guard lock(p.map.mutex);
    int n = 0;
    for (MapPoint* point : p.tracker.last_frame().points) {
      if (point == nullptr || point->bad || n++ % 4 != 0) continue;
      p.map.set_bad(point);
      culled.insert(point);
    }
  });
  for (frame = 0; frame < kFrames; ++frame) {
    window = 0;
    const TrackingResult& r = p.feed(static_cast<std::uint64_t>(frame), test::observe(w, frame, 23));
    ASSERT_EQ(r.state, TrackingState::ok) << "frame " << frame << ": " << r.lost_reason;
    // (Checked after local mapping ran on a new keyframe: its fusion may have merged some of the
    // frame's points since, which the next frame follows; the culled ones must not be there.)
    for (const MapPoint* point : p.tracker.last_frame().points) {
      ASSERT_EQ(culled.count(point), 0u) << "frame " << frame << " kept culled point " << point->id;
    }
  }
  EXPECT_GT(culled.size(), 100u);
}

constexpr int kMoved = 15;

/// Tracks kFrames frames with the lock released; in window `moved_in` (1-3) of frame kMoved every
/// keyframe and point moves by the rigid S, as a loop correction (`correction` true: the map's
/// correction count goes up) or a local BA written back (it does not) would move them. Checks that
/// frame kMoved and those after it are tracked in the moved map, at T_cw S^-1.
void track_with_the_map_moved(test::Pipeline& p, const test::World& w, std::uint64_t seed, const SE3& S,
                              int moved_in, bool correction) {
  p.tracker.release_map_lock_while_computing(true);
  int frame = 0, window = 0;
  p.tracker.set_unlocked_hook([&] {
    if (frame != kMoved || ++window != moved_in) return;
    std::lock_guard lock(p.map.mutex);
    for (KeyFrame* keyframe : p.map.keyframes()) keyframe->T_cw = keyframe->T_cw * S.inverse();
    for (MapPoint* point : p.map.points()) {
      point->position = S * point->position;
      point->normal = S.linear() * point->normal;
    }
    if (correction) ++p.map.correction_generation;
  });
  for (frame = 0; frame < kFrames; ++frame) {
    window = 0;
    const TrackingResult& r = p.feed(static_cast<std::uint64_t>(frame), test::observe(w, frame, seed));
    ASSERT_EQ(r.state, TrackingState::ok) << "window " << moved_in << ", frame " << frame << ": " << r.lost_reason;
    const SE3 moved = frame >= kMoved ? S.inverse() : SE3::Identity();
    const SE3 truth = w.T_cw[static_cast<std::size_t>(frame)] * moved;
    EXPECT_LT(translation_error_m(r.T_cw, truth), 0.03) << "window " << moved_in << ", frame " << frame;
    EXPECT_FALSE(r.relocalised) << "window " << moved_in << ", frame " << frame << ": " << r.lost_reason;
  }
  p.tracker.set_unlocked_hook({});
}

// A loop correction (here a rigid motion S of every keyframe and point) in each of the three
// windows of frame 15: that frame and the ones after it are tracked in the moved map, at T_cw S^-1.
TEST(TrackingMapLock, AMapMovedWhileTheLockIsReleasedMovesTheFrameWithIt) {
  SE3 S = SE3::Identity();
  S.linear() = Eigen::AngleAxisd(2.0 * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  S.translation() = Eigen::Vector3d(1.0, 0.0, 0.5);
  for (int moved_in : {1, 2, 3}) {
    const test::World w(straight_path(), 25, 1200, kFrames);
    test::Pipeline p(w, w.settings);
    track_with_the_map_moved(p, w, 25, S, moved_in, /*correction=*/true);
  }
}

// Local mapping's BA written back while the lock is released: it moves the frame's reference
// keyframe (here every keyframe and point by the same rigid S, without the loop closer's
// correction count). The frame's pose, computed from copies of the map before, is computed again
// from the map as it is, in each of the three windows of frame 15; frames after it are tracked in
// the moved map, and every frame's pose relative to its keyframe (TrackingResult::T_c_ref) puts it
// where its keyframe now is.
TEST(TrackingMapLock, AKeyframeMovedByLocalMappingWhileTheLockIsReleasedIsFollowed) {
  SE3 S = SE3::Identity();
  S.linear() = Eigen::AngleAxisd(0.5 * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  S.translation() = Eigen::Vector3d(0.2, 0.0, 0.1);
  for (int moved_in : {1, 2, 3}) {
    const test::World w(straight_path(), 29, 1200, kFrames);
    test::Pipeline p(w, w.settings);
    track_with_the_map_moved(p, w, 29, S, moved_in, /*correction=*/false);
    // The trajectory System writes: every frame with its keyframe's pose now, in the moved map.
    std::lock_guard lock(p.map.mutex);
    for (int k = 0; k < kFrames; ++k) {
      const TrackingResult& r = p.results[static_cast<std::size_t>(k)];
      const KeyFrame* reference = r.reference_keyframe;
      SE3 T_c_ref = r.T_c_ref;
      while (reference->bad && reference->parent != nullptr) {
        T_c_ref = T_c_ref * reference->T_c_parent;
        reference = reference->parent;
      }
      EXPECT_LT(translation_error_m(T_c_ref * reference->T_cw, w.T_cw[static_cast<std::size_t>(k)] * S.inverse()),
                0.03)
          << "window " << moved_in << ", frame " << k;
    }
  }
}

// The realtime arrangement: local mapping on its own thread, taking the lock whenever tracking
// lets it go (run under TSan in CI: tracking's work without the lock touches no map object).
TEST(TrackingMapLock, TracksBesideTheMappingThreadWithinCentimetres) {
  const test::World w(straight_path(), 27, 1200, kFrames);
  test::Pipeline p(w, w.settings);
  p.tracker.release_map_lock_while_computing(true);
  p.mapper.start();
  std::vector<TrackingResult> results;
  for (int k = 0; k < kFrames; ++k) {
    results.push_back(p.tracker.track(static_cast<std::uint64_t>(k), 0.1 * k, test::observe(w, k, 27)));
  }
  p.mapper.stop();
  for (int k = 0; k < kFrames; ++k) {
    const TrackingResult& r = results[static_cast<std::size_t>(k)];
    ASSERT_EQ(r.state, TrackingState::ok) << "frame " << k << ": " << r.lost_reason;
    EXPECT_LT(translation_error_m(r.T_cw, w.T_cw[static_cast<std::size_t>(k)]), 0.05) << "frame " << k;
  }
  // Keyframes beyond the first, mapped on the thread (how many depends on how fast it ran).
  EXPECT_GE(p.mapper.times().size(), 2u);
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
