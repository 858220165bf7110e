// Loop closing and relocalisation (slam/loop, slam/tracking/relocalisation) on the synthetic world
// of synthetic_world.hpp: a path that comes back to its start is closed (and stays accurate), a
// look-alike place (the same descriptors in a mirrored layout) is found by place recognition but
// refused by verification, and tracking lost by a covered lens or a kidnap relocalises as soon as
// the camera sees mapped scenery again. Everything runs as the deterministic pipeline does.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

#include "synthetic_world.hpp"

namespace porta::slam {
namespace {

using test::Pipeline;
using test::World;

double position_error_m(const SE3& estimate_cw, const SE3& truth_cw) {
  return (estimate_cw.inverse().translation() - truth_cw.inverse().translation()).norm();
}

// A circle of 120 frames (0.5 m and 3 degrees each: 60 m around), driven once and then 24 frames
// further, over the start again. The points are those seen on the first lap only.
constexpr int kLap = 120;

TEST(LoopClosing, ClosesTheLoopWhenThePathReturnsToItsStart) {
  const World w(test::straight_path(kLap + 24, 0.5, 3.0), 21, 2400, kLap);
  Pipeline p(w, w.settings, /*with_loop_closer=*/true);
  p.run(w, kLap + 24, 21);
  for (std::size_t k = 0; k < p.results.size(); ++k) {
    ASSERT_EQ(p.results[k].state, TrackingState::ok) << "frame " << k << ": " << p.results[k].lost_reason;
  }
  const LoopCloser& closer = *p.loop_closer;
  ASSERT_GE(closer.loops_closed(), 1u) << "the second pass over the start was not recognised";
  const LoopEvent* first = nullptr;
  for (const LoopEvent& e : closer.loops()) {
    if (e.closed && first == nullptr) first = &e;
  }
  ASSERT_NE(first, nullptr);
  EXPECT_GE(first->frame, static_cast<std::uint64_t>(kLap - 5)) << "closed before the path came back";
  EXPECT_LE(first->loop_frame, 30u) << "closed with a keyframe far from the start";
  EXPECT_GE(first->inliers, 40);
  // Both keyframes keep the loop edge.
  const KeyFrame* a = p.map.keyframe_by_id(first->keyframe);
  const KeyFrame* b = p.map.keyframe_by_id(first->loop_keyframe);
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(a->loop_edges.count(const_cast<KeyFrame*>(b)), 1u);
  EXPECT_EQ(b->loop_edges.count(const_cast<KeyFrame*>(a)), 1u);
  // After correction and global bundle adjustment the keyframes lie on the true path.
  EXPECT_GE(closer.global_ba_runs().size(), 1u);
  double worst = 0.0;
  for (const KeyFrame* k : p.map.keyframes()) {
    worst = std::max(worst, position_error_m(k->T_cw, w.T_cw[static_cast<std::size_t>(k->frame_id)]));
  }
  EXPECT_LT(worst, 0.10) << "keyframe position error after the loop";
  std::printf("loop: keyframe %llu (frame %llu) with %llu (frame %llu), %d matches, %d inliers; worst keyframe error %.4f m\n",
              static_cast<unsigned long long>(first->keyframe), static_cast<unsigned long long>(first->frame),
              static_cast<unsigned long long>(first->loop_keyframe), static_cast<unsigned long long>(first->loop_frame),
              first->matches, first->inliers, worst);
}

TEST(LoopClosing, SameInputGivesBitIdenticalMapsWithLoopClosing) {
  const World w(test::straight_path(kLap + 24, 0.5, 3.0), 23, 2400, kLap);
  Pipeline first(w, w.settings, true), second(w, w.settings, true);
  first.run(w, kLap + 24, 23);
  second.run(w, kLap + 24, 23);
  EXPECT_EQ(first.loop_closer->loops_closed(), second.loop_closer->loops_closed());
  const auto a = first.map.keyframes(), b = second.map.keyframes();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(std::memcmp(a[k]->T_cw.data(), b[k]->T_cw.data(), sizeof(double) * 16), 0) << "keyframe " << a[k]->id;
  }
}

// Frames 80-119 see, besides their own points, a mirrored copy of what frames 0-39 saw: the same
// descriptors with the same co-visibility, so place recognition scores the old keyframes highly,
// but no rigid motion maps one layout onto the other.
TEST(LoopClosing, RefusesALookAlikePlaceWhoseGeometryDoesNotFit) {
  World w(test::straight_path(120, 0.3, 1.0), 25, 1800, 120, 10.0);
  const std::size_t originals = w.points.size();
  for (std::size_t j = 0; j < originals; ++j) {
    const int k = w.host_frame[j];
    if (k >= 40) continue;
    Eigen::Vector3d in_camera = w.T_cw[static_cast<std::size_t>(k)] * w.points[j];
    in_camera.x() = -in_camera.x();
    w.points.push_back(w.T_cw[static_cast<std::size_t>(k + 80)].inverse() * in_camera);
    w.descriptors.push_back(w.descriptors[j]);
    w.level0_distance_m.push_back(w.level0_distance_m[j]);
    w.angle_bin.push_back(w.angle_bin[j]);
    w.host_frame.push_back(k + 80);
  }
  Pipeline p(w, w.settings, true);
  p.run(w, 120, 25);
  for (std::size_t k = 0; k < p.results.size(); ++k) {
    ASSERT_EQ(p.results[k].state, TrackingState::ok) << "frame " << k << ": " << p.results[k].lost_reason;
  }
  const LoopCloser& closer = *p.loop_closer;
  EXPECT_EQ(closer.loops_closed(), 0u) << "a false loop was closed";
  ASSERT_FALSE(closer.loops().empty()) << "the look-alike was never even proposed: the test shows nothing";
  for (const LoopEvent& e : closer.loops()) {
    EXPECT_FALSE(e.rejected.empty());
    EXPECT_LT(e.loop_frame, 45u);
    std::printf("look-alike: keyframe %llu vs %llu refused: %s\n", static_cast<unsigned long long>(e.keyframe),
                static_cast<unsigned long long>(e.loop_keyframe), e.rejected.c_str());
  }
}

// ---- Relocalisation -------------------------------------------------------------------------------

TEST(Relocalisation, CoveredLensThenTheSameViewAgainRelocalisesAtOnce) {
  const World w(test::straight_path(90, 0.3, 1.0), 27, 1500, 80);
  Pipeline p(w, w.settings, true);
  p.run(w, 40, 27);
  // 30 frames without a single feature (a covered lens), then the camera where it was.
  std::uint64_t id = 40;
  for (int k = 0; k < 30; ++k, ++id) {
    const TrackingResult& r = p.feed(id, std::make_shared<FrameFeatures>());
    EXPECT_EQ(r.state, TrackingState::lost) << "frame " << id;
    EXPECT_FALSE(r.lost_reason.empty());
  }
  const TrackingResult& back = p.feed(id++, test::observe(w, 40, 27));
  ASSERT_EQ(back.state, TrackingState::ok) << back.lost_reason;
  EXPECT_TRUE(back.relocalised);
  EXPECT_LT(position_error_m(back.T_cw, w.T_cw[40]), 0.05);
  for (int k = 41; k < 60; ++k, ++id) {
    const TrackingResult& r = p.feed(id, test::observe(w, k, 27));
    ASSERT_EQ(r.state, TrackingState::ok) << "frame " << id << ": " << r.lost_reason;
    EXPECT_FALSE(r.relocalised) << "frame " << id << ": tracked again, no relocalisation needed";
    EXPECT_LT(position_error_m(r.T_cw, w.T_cw[static_cast<std::size_t>(k)]), 0.05) << "frame " << id;
  }
}

TEST(Relocalisation, KidnappedToAnEarlierPlaceRelocalisesThereWithinCentimetres) {
  const World w(test::straight_path(90, 0.3, 1.0), 29, 1500, 80);
  Pipeline p(w, w.settings, true);
  p.run(w, 60, 29);
  // Carried back 45 frames (13.5 m): the next frame shows the place of frame 15.
  std::uint64_t id = 60;
  int lost = 0;
  bool relocalised = false;
  for (int k = 15; k < 35; ++k, ++id) {
    const TrackingResult& r = p.feed(id, test::observe(w, k, 29));
    if (r.state == TrackingState::lost) {
      ++lost;
      EXPECT_FALSE(relocalised) << "lost again after relocalising, frame " << id << ": " << r.lost_reason;
      continue;
    }
    if (!relocalised) {
      EXPECT_TRUE(r.relocalised) << "frame " << id;
      relocalised = true;
      EXPECT_LE(k - 15, 5) << "relocalised only at the " << k - 15 + 1 << "th frame of the mapped place";
    }
    EXPECT_LT(position_error_m(r.T_cw, w.T_cw[static_cast<std::size_t>(k)]), 0.05) << "frame " << id;
  }
  EXPECT_TRUE(relocalised);
  int relocalisations = 0;
  for (const TrackingResult& r : p.results) relocalisations += r.relocalised ? 1 : 0;
  EXPECT_EQ(relocalisations, 1) << "after relocalising, the motion model takes over again";
}

TEST(Relocalisation, WithoutALoopCloserTrackingStaysLostAndSaysWhy) {
  const World w(test::straight_path(40, 0.3, 1.0), 31, 1200, 30);
  Pipeline p(w, w.settings, false);
  p.run(w, 10, 31);
  const TrackingResult& lost = p.feed(10, test::observe(w, 10, 31, true));
  ASSERT_EQ(lost.state, TrackingState::lost);
  const TrackingResult& again = p.feed(11, test::observe(w, 11, 31));
  EXPECT_EQ(again.state, TrackingState::lost);
  EXPECT_NE(again.lost_reason.find("relocalisation is off"), std::string::npos) << again.lost_reason;
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
