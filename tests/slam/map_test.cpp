// The SLAM map's bookkeeping: observations both ways, the covisibility graph and its weights,
// the spanning tree when a keyframe is culled, point culling and duplicate fusion, descriptors and
// scale prediction; the frame's feature grid and the conversion of the frontend's output.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <random>
#include <thread>

#include "porta/slam/map.hpp"
#include "porta/tables.hpp"

namespace porta::slam {
namespace {

const StereoCamera kCamera{640, 480, 500.0, 500.0, 320.0, 240.0, 0.1};

/// `n` features on a regular grid, levels cycling 0..3, every second one with depth.
std::shared_ptr<const FrameFeatures> grid_features(int n, std::uint8_t descriptor_seed = 0) {
  auto f = std::make_shared<FrameFeatures>();
  for (int i = 0; i < n; ++i) {
    f->uv.emplace_back(10.0f + 37.0f * (i % 16), 10.0f + 29.0f * (i / 16));
    f->level.push_back(static_cast<std::uint8_t>(i % 4));
    f->angle_rad.push_back(0.0f);
    Descriptor d;
    d.bytes.fill(static_cast<std::uint8_t>(descriptor_seed + i));
    f->descriptors.push_back(d);
    f->u_right.push_back(i % 2 == 0 ? f->uv.back().x() - 10.0f : -1.0f);
    f->depth_m.push_back(i % 2 == 0 ? static_cast<float>(kCamera.bf() / 10.0) : -1.0f);
  }
  return f;
}

Frame make_frame(std::uint64_t id, int n) { return Frame(id, 0.1 * id, grid_features(n), kCamera); }

TEST(Map, ObservationsAreLinkedBothWaysAndCountStereoTwice) {
  Map map;
  KeyFrame* kf = map.add_keyframe(make_frame(0, 40));
  MapPoint* p = map.add_point(Eigen::Vector3d(0, 0, 5), kf, 0);
  Map::add_observation(p, kf, 4);  // feature 4 has depth
  EXPECT_EQ(kf->points[4], p);
  EXPECT_EQ(p->observations.at(kf), 4);
  EXPECT_EQ(p->num_observations(), 2);
  KeyFrame* kf2 = map.add_keyframe(make_frame(1, 40));
  Map::add_observation(p, kf2, 5);  // feature 5 is mono
  EXPECT_EQ(p->num_observations(), 3);
  EXPECT_EQ(kf->tracked_points(3), 1);
  EXPECT_EQ(kf->tracked_points(4), 0);
}

TEST(Map, ErasingObservationsCullsAPointLeftWithTwoOrFewer) {
  Map map;
  KeyFrame* a = map.add_keyframe(make_frame(0, 40));
  KeyFrame* b = map.add_keyframe(make_frame(1, 40));
  MapPoint* p = map.add_point(Eigen::Vector3d(0, 0, 5), a, 0);
  Map::add_observation(p, a, 1);  // mono
  Map::add_observation(p, b, 3);  // mono
  Map::add_observation(p, map.add_keyframe(make_frame(2, 40)), 8);  // stereo: counts twice
  Map::erase_observation(p, a);
  EXPECT_FALSE(p->bad);  // 3 observations left
  EXPECT_EQ(a->points[1], nullptr);
  EXPECT_EQ(p->reference, b);  // the reference moves to a remaining observer
  Map::erase_observation(p, b);
  EXPECT_TRUE(p->bad);  // one stereo observation (2) left
  EXPECT_TRUE(p->observations.empty());
  EXPECT_EQ(map.num_points(), 0u);
}

/// Three keyframes: A and B share 20 points, B and C share 16, A and C share 3.
struct Triangle {
  Map map;
  KeyFrame *a, *b, *c;
  Triangle() {
    a = map.add_keyframe(make_frame(0, 80));
    b = map.add_keyframe(make_frame(1, 80));
    c = map.add_keyframe(make_frame(2, 80));
    int feature = 0;
    auto share = [&](std::vector<KeyFrame*> kfs, int count) {
      for (int i = 0; i < count; ++i, ++feature) {
        MapPoint* p = map.add_point(Eigen::Vector3d(feature, 0, 5), kfs[0], 0);
        for (KeyFrame* kf : kfs) Map::add_observation(p, kf, feature);
      }
    };
    share({a, b}, 20);
    share({b, c}, 16);
    share({a, c}, 3);
    a->update_connections();
    b->update_connections();
    c->update_connections();
  }
};

TEST(Map, CovisibilityWeightsAreSharedPointsAboveTheMinimum) {
  Triangle t;
  EXPECT_EQ(t.a->connections.at(t.b), 20);
  EXPECT_EQ(t.b->connections.at(t.a), 20);
  EXPECT_EQ(t.b->connections.at(t.c), 16);
  // 3 < 15 shared points: no edge between A and C...
  EXPECT_EQ(t.a->connections.count(t.c), 0u);
  EXPECT_EQ(t.c->connections.count(t.a), 0u);
  EXPECT_EQ(t.b->best_covisibles(5), (std::vector<KeyFrame*>{t.a, t.c}));
  EXPECT_EQ(t.b->best_covisibles(1), (std::vector<KeyFrame*>{t.a}));
  EXPECT_EQ(t.b->covisibles_with_weight(17), (std::vector<KeyFrame*>{t.a}));
  // ...unless it is a keyframe's only connection: the best one is always kept.
  Map map;
  KeyFrame* x = map.add_keyframe(make_frame(0, 10));
  KeyFrame* y = map.add_keyframe(make_frame(1, 10));
  MapPoint* p = map.add_point(Eigen::Vector3d(0, 0, 5), x, 0);
  Map::add_observation(p, x, 0);
  Map::add_observation(p, y, 0);
  y->update_connections();
  EXPECT_EQ(y->connections.at(x), 1);
  EXPECT_EQ(y->parent, x);
}

TEST(Map, SpanningTreeParentIsTheStrongestConnectionAndSurvivesCulling) {
  Triangle t;
  EXPECT_EQ(t.a->parent, nullptr);  // keyframe 0 is the root
  EXPECT_EQ(t.b->parent, t.a);
  EXPECT_EQ(t.c->parent, t.b);
  // Culling B: its points lose an observer (those left with <= 2 observations go bad), its edges
  // disappear, and C is re-parented. C shares nothing strong with A any more, so it hangs on A.
  Map::set_bad(t.b);
  EXPECT_TRUE(t.b->bad);
  EXPECT_EQ(t.a->connections.count(t.b), 0u);
  EXPECT_EQ(t.c->connections.count(t.b), 0u);
  EXPECT_EQ(t.c->parent, t.a);
  EXPECT_EQ(t.a->children.count(t.c), 1u);
  EXPECT_EQ(t.map.num_keyframes(), 2u);
  for (MapPoint* p : t.b->points) EXPECT_EQ(p, nullptr);
  // Keyframe 0 is never culled.
  Map::set_bad(t.a);
  EXPECT_FALSE(t.a->bad);
}

TEST(Map, ReplaceMovesObservationsAndKeepsOnePerKeyframe) {
  Map map;
  KeyFrame* a = map.add_keyframe(make_frame(0, 40));
  KeyFrame* b = map.add_keyframe(make_frame(1, 40));
  KeyFrame* c = map.add_keyframe(make_frame(2, 40));
  MapPoint* keep = map.add_point(Eigen::Vector3d(0, 0, 5), a, 0);
  MapPoint* dup = map.add_point(Eigen::Vector3d(0, 0, 5.01), b, 0);
  Map::add_observation(keep, a, 2);
  Map::add_observation(keep, b, 2);
  Map::add_observation(dup, b, 6);  // b sees both: after fusion only feature 2 keeps the point
  Map::add_observation(dup, c, 8);
  Map::replace(dup, keep);
  EXPECT_TRUE(dup->bad);
  EXPECT_EQ(dup->replaced_by, keep);
  EXPECT_EQ(c->points[8], keep);
  EXPECT_EQ(b->points[2], keep);
  EXPECT_EQ(b->points[6], nullptr);
  EXPECT_EQ(keep->observations.size(), 3u);
}

TEST(Map, RepresentativeDescriptorHasTheLeastMedianDistance) {
  Map map;
  std::vector<KeyFrame*> kfs;
  // Descriptors with 0, 8, 12 and 200 bits set: median distances 8, 4, 4, 188 (each row includes
  // the zero distance to itself); the tie goes to the earlier keyframe, the one with 8 bits.
  const int bits[] = {0, 8, 12, 200};
  MapPoint* p = nullptr;
  for (int k = 0; k < 4; ++k) {
    auto f = std::make_shared<FrameFeatures>(*grid_features(1));
    f->descriptors[0].bytes.fill(0);
    for (int j = 0; j < bits[k]; ++j) f->descriptors[0].bytes[j / 8] |= static_cast<std::uint8_t>(1u << (j % 8));
    KeyFrame* kf = map.add_keyframe(Frame(k, 0.0, f, kCamera));
    if (p == nullptr) p = map.add_point(Eigen::Vector3d(0, 0, 5), kf, 0);
    Map::add_observation(p, kf, 0);
  }
  p->update_descriptor();
  EXPECT_EQ(hamming_distance(p->descriptor, Descriptor{}), 8);
}

// Above 32 observations the distance table moves from the stack to the heap: same rule there.
// Observation k (0..40) has its first k bits set, so distances are |a - b|: the median of a's row
// is 10 for every a in 10..30 and larger outside, and the tie goes to the earliest, a = 10.
TEST(Map, RepresentativeDescriptorOfAPointSeenByManyKeyframes) {
  Map map;
  MapPoint* p = nullptr;
  for (int k = 0; k <= 40; ++k) {
    auto f = std::make_shared<FrameFeatures>(*grid_features(1));
    f->descriptors[0].bytes.fill(0);
    for (int j = 0; j < k; ++j) f->descriptors[0].bytes[j / 8] |= static_cast<std::uint8_t>(1u << (j % 8));
    KeyFrame* kf = map.add_keyframe(Frame(k, 0.0, f, kCamera));
    if (p == nullptr) p = map.add_point(Eigen::Vector3d(0, 0, 5), kf, 0);
    Map::add_observation(p, kf, 0);
  }
  ASSERT_EQ(p->observations.size(), 41u);
  p->update_descriptor();
  EXPECT_EQ(hamming_distance(p->descriptor, Descriptor{}), 10);
}

TEST(Map, ScaleRangeAndPredictedLevel) {
  const ScalePyramid pyramid(8, 1.2);
  Map map;
  Frame frame = make_frame(0, 40);
  KeyFrame* kf = map.add_keyframe(frame);
  MapPoint* p = map.add_point(Eigen::Vector3d(0, 0, 10), kf, 0);
  Map::add_observation(p, kf, 2);  // level 2
  p->update_normal_and_depth(pyramid);
  EXPECT_NEAR(p->max_distance, 10.0 * 1.44, 1e-9);
  EXPECT_NEAR(p->min_distance, 10.0 * 1.44 / std::pow(1.2, 7), 1e-9);
  EXPECT_NEAR(p->normal.z(), 1.0, 1e-12);
  EXPECT_EQ(p->predict_level(10.5, pyramid), 2);       // about where it was made: same level
  EXPECT_EQ(p->predict_level(10.0 * 1.44, pyramid), 0);  // farther: finer level
  EXPECT_EQ(p->predict_level(0.01, pyramid), 7);         // clamped to the top
}

// Local mapping's fusion holds the map for milliseconds; between its steps it hands the lock to a
// tracker waiting in lock_first() and takes it back once the tracker is done.
TEST(Map, YieldHandsTheLockToALockFirstWaiterAndTakesItBack) {
  Map map;
  std::unique_lock lock(map.mutex);
  EXPECT_FALSE(map.yield_to_waiters(lock));  // nobody waits: the lock is kept
  EXPECT_TRUE(lock.owns_lock());
  std::atomic<bool> tracked{false};
  std::thread tracker([&] {
    const std::unique_lock<MapMutex> tracking = map.lock_first();
    tracked = true;
  });
  EXPECT_FALSE(tracked.load());  // it cannot run while the lock is held
  while (!map.yield_to_waiters(lock)) std::this_thread::yield();
  EXPECT_TRUE(lock.owns_lock());
  EXPECT_TRUE(tracked.load());  // it ran in between, and was done before the lock came back
  tracker.join();
  EXPECT_FALSE(map.yield_to_waiters(lock));
}

TEST(Map, TheMutexAddsUpEachThreadsWaitsToTakeIt) {
  Map map;
  const std::int64_t before = MapMutex::thread_wait_ns();
  { std::lock_guard lock(map.mutex); }  // not contended: nothing waited
  EXPECT_EQ(MapMutex::thread_wait_ns(), before);

  constexpr auto kHeld = std::chrono::milliseconds(100);
  std::unique_lock lock(map.mutex);
  std::atomic<bool> asked{false};
  std::int64_t waited_ns = -1;
  std::thread other([&] {
    const std::int64_t start = MapMutex::thread_wait_ns();  // a new thread starts at its own count
    asked = true;
    { std::lock_guard taken(map.mutex); }
    waited_ns = MapMutex::thread_wait_ns() - start;
  });
  while (!asked.load()) std::this_thread::yield();
  std::this_thread::sleep_for(kHeld);  // it reaches lock() within microseconds of asking
  lock.unlock();
  other.join();
  EXPECT_EQ(MapMutex::thread_wait_ns(), before) << "the holder waited for nothing";
  EXPECT_GT(waited_ns, 0) << "the other thread's wait was not counted";
  EXPECT_LE(waited_ns, std::chrono::nanoseconds(kHeld).count() + 1'000'000'000);
}

TEST(FeatureGrid, InAreaMatchesBruteForce) {
  std::mt19937 rng(7);
  auto f = std::make_shared<FrameFeatures>();
  std::uniform_real_distribution<float> x(0, 639), y(0, 479);
  for (int i = 0; i < 2000; ++i) {
    f->uv.emplace_back(x(rng), y(rng));
    f->level.push_back(static_cast<std::uint8_t>(i % 8));
  }
  const FeatureGrid grid(*f, 640, 480);
  for (int q = 0; q < 50; ++q) {
    const float u = x(rng), v = y(rng), r = 5.0f + q;
    std::vector<int> expected;
    for (int i = 0; i < 2000; ++i) {
      if (std::abs(f->uv[i].x() - u) <= r && std::abs(f->uv[i].y() - v) <= r && f->level[i] >= 1 &&
          f->level[i] <= 5) {
        expected.push_back(i);
      }
    }
    EXPECT_EQ(grid.in_area(*f, u, v, r, 1, 5), expected) << "query " << q;
  }
}

TEST(FrameFeatures, FromFrontendMovesToLevelZeroAndComputesDepth) {
  FrontendSettings settings;
  const FrontendTables tables = FrontendTables::build(settings, 640, 480);
  StereoFeatures stereo;
  stereo.left.keypoints = {Keypoint{100, 50, 30, 0, 0}, Keypoint{100, 50, 30, 2, 4}};
  stereo.left.descriptors.resize(2);
  stereo.matches = {StereoMatch{20 * 256, 0}, StereoMatch{-1, -1}};
  const FrameFeatures f = FrameFeatures::from_frontend(stereo, tables, kCamera);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_FLOAT_EQ(f.uv[0].x(), 100.0f);
  EXPECT_NEAR(f.uv[1].x(), 100.0 * 1.44, 1e-3);  // level 2 at scale 1.2
  EXPECT_FLOAT_EQ(f.u_right[0], 80.0f);
  EXPECT_FLOAT_EQ(f.depth_m[0], static_cast<float>(kCamera.bf() / 20.0));
  EXPECT_FALSE(f.has_depth(1));
  EXPECT_NEAR(f.angle_rad[1], orientation_bin_center_rad(4, settings.orientation_bins), 1e-6);
  // The stereo point lands where its depth says: back-projection of feature 0.
  Frame frame(0, 0.0, std::make_shared<FrameFeatures>(f), kCamera);
  const Eigen::Vector3d p = frame.unproject_stereo(0, kCamera);
  EXPECT_NEAR(p.z(), 2.5, 1e-6);
  EXPECT_NEAR(p.x(), (100.0 - 320.0) * 2.5 / 500.0, 1e-6);
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
