// Tracking's local-point list kept across frames (slam/tracking/local_points.hpp): after any edit
// of the map, its good points are those of a scan of every local keyframe, in the same order.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <set>
#include <vector>

#include "porta/slam/map.hpp"
#include "slam/tracking/local_points.hpp"

namespace porta::slam {
namespace {

const StereoCamera kCamera{640, 480, 500.0, 500.0, 320.0, 240.0, 0.1};

Frame make_frame(std::uint64_t id, int features) {
  auto f = std::make_shared<FrameFeatures>();
  for (int i = 0; i < features; ++i) {
    f->uv.emplace_back(5.0f + 9.0f * (i % 64), 5.0f + 9.0f * (i / 64));
    f->level.push_back(0);
    f->angle_rad.push_back(0.0f);
    f->descriptors.emplace_back();
    f->u_right.push_back(-1.0f);
    f->depth_m.push_back(-1.0f);
  }
  return Frame(id, 0.1 * static_cast<double>(id), f, kCamera);
}

/// The reference: every keyframe scanned in order, each good point once where first met.
std::vector<MapPoint*> scan_all(const std::vector<KeyFrame*>& keyframes) {
  std::vector<MapPoint*> out;
  std::set<const MapPoint*> seen;
  for (const KeyFrame* keyframe : keyframes) {
    for (MapPoint* point : keyframe->points) {
      if (point != nullptr && !point->bad && seen.insert(point).second) out.push_back(point);
    }
  }
  return out;
}

std::vector<MapPoint*> good(const std::vector<MapPoint*>& points) {
  std::vector<MapPoint*> out;
  for (MapPoint* point : points) {
    if (!point->bad) out.push_back(point);
  }
  return out;
}

TEST(TrackingLocalPoints, KeepsEachKeyframesShareWhileTheKeyframesBeforeGaveTheirsAgain) {
  Map map;
  std::vector<KeyFrame*> keyframes;
  for (int k = 0; k < 3; ++k) keyframes.push_back(map.add_keyframe(make_frame(k, 10)));
  // Keyframe k sees points 3k .. 3k+5 (its own three and the next keyframe's first three).
  std::vector<MapPoint*> points;
  for (int p = 0; p < 12; ++p) points.push_back(map.add_point(Eigen::Vector3d(0, 0, 5), keyframes[0], 0));
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 6; ++j) Map::add_observation(points[3 * k + j], keyframes[k], j);
  }
  tracking::LocalPoints local;
  local.update(keyframes);
  ASSERT_EQ(local.points().size(), 12u);
  EXPECT_EQ(local.kept(), 0u);
  EXPECT_EQ(local.scanned(), 30u);

  local.update(keyframes);  // nothing changed: nothing scanned
  EXPECT_EQ(local.kept(), 12u);
  EXPECT_EQ(local.scanned(), 0u);
  EXPECT_EQ(local.points(), scan_all(keyframes));

  // An edit of keyframe 1: keyframe 0's six points stay, keyframes 1 and 2 are scanned again.
  MapPoint* fresh = map.add_point(Eigen::Vector3d(0, 0, 5), keyframes[1], 1);
  Map::add_observation(fresh, keyframes[1], 9);
  local.update(keyframes);
  EXPECT_EQ(local.kept(), 6u);
  EXPECT_EQ(local.scanned(), 20u);
  EXPECT_EQ(local.points(), scan_all(keyframes));
  EXPECT_EQ(local.points()[9], fresh);  // keyframe 0's points 0..5, keyframe 1's 6..8, then its feature 9's

  // Keyframe 1 stops seeing point 3, which keyframe 0 met first: its share is as before, so
  // keyframe 2 keeps its three points (9..11) without a scan.
  keyframes[1]->set_point(0, nullptr);
  local.update(keyframes);
  EXPECT_EQ(local.kept(), 9u);
  EXPECT_EQ(local.scanned(), 10u);
  EXPECT_EQ(local.points(), scan_all(keyframes));
  // Point 4 culled: keyframes 0 and 1 lose it (edited, scanned), their shares of good points are as
  // before, keyframe 2 keeps its share.
  Map::set_bad(points[4]);
  local.update(keyframes);
  EXPECT_EQ(local.kept(), 3u);
  EXPECT_EQ(local.scanned(), 20u);
  EXPECT_EQ(local.points(), scan_all(keyframes));

  // A point that only an unlinked slot of keyframe 2 holds (tracking's new keyframe, before local
  // mapping links it), culled: no listed keyframe is edited, so the list keeps it, bad.
  KeyFrame* elsewhere = map.add_keyframe(make_frame(3, 10));
  MapPoint* unlinked = map.add_point(Eigen::Vector3d(0, 0, 5), elsewhere, 3);
  Map::add_observation(unlinked, elsewhere, 0);
  keyframes[2]->set_point(8, unlinked);
  local.update(keyframes);
  EXPECT_EQ(local.points().back(), unlinked);
  Map::set_bad(unlinked);
  EXPECT_EQ(keyframes[2]->points[8], unlinked);
  local.update(keyframes);
  EXPECT_EQ(local.kept(), local.points().size());
  EXPECT_EQ(local.points().back(), unlinked);
  EXPECT_EQ(good(local.points()), scan_all(keyframes));

  // Another list: only the common leading keyframe's share is kept (0..3 and 5; 4 was culled).
  const std::vector<KeyFrame*> swapped{keyframes[0], keyframes[2], keyframes[1]};
  local.update(swapped);
  EXPECT_EQ(local.kept(), 5u);
  EXPECT_EQ(local.points(), scan_all(swapped));
}

TEST(TrackingLocalPoints, EqualsAScanOfEveryKeyframeThroughRandomEdits) {
  std::mt19937 rng(11);
  const auto draw = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); };
  constexpr int kKeyframes = 14, kFeatures = 40;
  Map map;
  std::vector<KeyFrame*> keyframes;
  for (int k = 0; k < kKeyframes; ++k) keyframes.push_back(map.add_keyframe(make_frame(k, kFeatures)));
  std::vector<MapPoint*> points;
  const auto new_point = [&] {
    MapPoint* p = map.add_point(Eigen::Vector3d(0, 0, 5), keyframes[0], 0);
    points.push_back(p);
    return p;
  };
  // Each point seen by 3-6 consecutive keyframes at a free feature.
  const auto observe = [&](MapPoint* p, int first, int count) {
    for (int k = first; k < std::min(first + count, kKeyframes); ++k) {
      KeyFrame* keyframe = keyframes[static_cast<std::size_t>(k)];
      const int feature = draw(kFeatures);
      if (keyframe->points[static_cast<std::size_t>(feature)] == nullptr) Map::add_observation(p, keyframe, feature);
    }
  };
  for (int i = 0; i < 150; ++i) observe(new_point(), draw(kKeyframes), 3 + draw(4));

  tracking::LocalPoints local;
  std::vector<KeyFrame*> list(keyframes.begin(), keyframes.begin() + 8);
  std::size_t kept_updates = 0;
  for (int round = 0; round < 400; ++round) {
    // One edit of the map, as local mapping or tracking makes them (or none).
    MapPoint* some = points[static_cast<std::size_t>(draw(static_cast<int>(points.size())))];
    KeyFrame* keyframe = keyframes[static_cast<std::size_t>(draw(kKeyframes))];
    const auto feature = static_cast<std::size_t>(draw(kFeatures));
    switch (draw(8)) {
      case 0:  // triangulation: a new point
        observe(new_point(), draw(kKeyframes), 2 + draw(4));
        break;
      case 1:  // an observation dropped (the point may go bad)
        if (!some->bad && !some->observations.empty()) Map::erase_observation(some, some->observations.begin()->first);
        break;
      case 2:  // culled
        if (!some->bad) Map::set_bad(some);
        break;
      case 3: {  // fused into another
        MapPoint* into = points[static_cast<std::size_t>(draw(static_cast<int>(points.size())))];
        if (!some->bad && !into->bad) Map::replace(some, into);
        break;
      }
      case 4:  // tracking's keyframe: a slot set without the point's observation (linked later)
        if (!some->bad && keyframe->points[feature] == nullptr) keyframe->set_point(feature, some);
        break;
      case 5:  // linking drops a slot
        if (keyframe->points[feature] != nullptr) keyframe->set_point(feature, nullptr);
        break;
      default:
        break;
    }
    // The next frame's local keyframes: mostly the same, sometimes one more, one fewer or reordered.
    switch (draw(6)) {
      case 0:
        if (list.size() < keyframes.size()) list.push_back(keyframes[list.size()]);
        break;
      case 1:
        if (list.size() > 2) list.erase(list.begin() + draw(static_cast<int>(list.size())));
        break;
      case 2:
        std::swap(list[static_cast<std::size_t>(draw(static_cast<int>(list.size())))], list.back());
        break;
      default:
        break;
    }
    local.update(list);
    const std::vector<MapPoint*> listed = local.points();
    ASSERT_EQ(good(listed), scan_all(list)) << "round " << round;
    kept_updates += local.kept() > 0 ? 1 : 0;
  }
  local.clear();  // a fresh scan lists no bad point
  local.update(list);
  EXPECT_EQ(local.kept(), 0u);
  EXPECT_EQ(local.points(), scan_all(list));
  EXPECT_GT(kept_updates, 100u);  // the rounds did keep lists
}

}  // namespace
}  // namespace porta::slam
#endif  // PORTA_SLAM_BUILT
