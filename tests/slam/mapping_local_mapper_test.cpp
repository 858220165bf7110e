// Local mapping on synthetic keyframes (mapping_scene.hpp): triangulation of the points tracking
// left unmatched, duplicate fusion, local bundle adjustment with keyframe 0 fixed, keyframe culling,
// and the realtime and deterministic modes giving the same bytes.
#if PORTA_SLAM_BUILT
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "mapping_scene.hpp"
#include "porta/slam/loop_closer.hpp"

namespace porta::slam::mapping_test {
namespace {

/// Inserts every keyframe of the scene at `poses` and lets the mapper process each before the next.
void run_deterministic(const SyntheticScene& scene, const std::vector<SE3>& poses, Map& map,
                       LocalMapper& mapper) {
  TrackingStandIn tracking(scene, map, mapper);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    tracking.insert(k, poses[k]);
    mapper.process_all();
  }
}

/// The scene point a map point stands for, when all its observations agree; -1 otherwise.
int scene_point_of(const MapPoint& point, const SyntheticScene& scene) {
  int j = -2;
  for (const auto& [keyframe, feature] : point.observations) {
    const int t = scene.truth[keyframe->frame_id][static_cast<std::size_t>(feature)];
    if (j == -2) j = t;
    if (t != j) return -1;
  }
  return j < 0 ? -1 : j;
}

double center_error_m(const SE3& T_cw, const SE3& truth) {
  return (T_cw.inverse().translation() - truth.inverse().translation()).norm();
}

double rotation_error_rad(const SE3& T_cw, const SE3& truth) {
  return rotation_angle_rad(T_cw.linear() * truth.linear().transpose());
}

TEST(Mapping, TriangulatesTheUnmatchedFarPointsNearTheTruth) {
  const SyntheticScene scene{SceneSpec{}};
  Map map;
  LocalMapper mapper(test_settings(), map);
  run_deterministic(scene, scene.true_T_cw, map, mapper);
  ASSERT_EQ(mapper.times().size(), scene.true_T_cw.size());
  EXPECT_GT(mapper.points_triangulated(), 0u);

  std::lock_guard lock(map.mutex);
  std::vector<double> errors;
  std::vector<bool> far_found(scene.points.size(), false);
  int wrong_associations = 0;
  for (const MapPoint* point : map.points()) {
    const int j = scene_point_of(*point, scene);
    if (j < 0) {
      ++wrong_associations;
      continue;
    }
    if (scene.points[static_cast<std::size_t>(j)].near) continue;
    far_found[static_cast<std::size_t>(j)] = true;
    errors.push_back((point->position - scene.points[static_cast<std::size_t>(j)].position).norm());
  }
  ASSERT_GT(errors.size(), 0u);
  std::sort(errors.begin(), errors.end());
  const int far_points = SceneSpec{}.far_points;
  const auto found = std::count(far_found.begin(), far_found.end(), true);
  std::printf("far points mapped %ld of %d, error median %.4f m, max %.4f m, wrong associations %d\n",
              static_cast<long>(found), far_points, errors[errors.size() / 2], errors.back(),
              wrong_associations);
  EXPECT_GE(found, far_points / 2);
  EXPECT_LT(errors[errors.size() / 2], 0.03);
  EXPECT_LT(errors.back(), 0.15);
  EXPECT_EQ(wrong_associations, 0);
}

TEST(Mapping, FusionMergesADuplicatedPoint) {
  SceneSpec spec;
  spec.keyframes = 2;
  spec.far_points = 0;
  spec.clutter = 0;
  spec.detect_probability = 1.0;
  const SyntheticScene scene(spec);
  Map map;
  LocalMapper mapper(test_settings(), map);
  TrackingStandIn tracking(scene, map, mapper);
  KeyFrame* first = tracking.insert(0, scene.true_T_cw[0]);
  mapper.process_all();
  // A near point both keyframes see: the stand-in gives the second keyframe a new point for it.
  int duplicated = -1;
  for (std::size_t i = 0; i < scene.truth[1].size() && duplicated < 0; ++i) {
    const int j = scene.truth[1][i];
    if (j >= 0 && tracking.resolve(j) != nullptr) duplicated = j;
  }
  ASSERT_GE(duplicated, 0);
  MapPoint* original = tracking.resolve(duplicated);
  KeyFrame* second = tracking.insert(1, scene.true_T_cw[1], duplicated);
  MapPoint* duplicate = tracking.resolve(duplicated);
  ASSERT_NE(original, duplicate);
  mapper.process_all();

  std::lock_guard lock(map.mutex);
  EXPECT_GE(mapper.points_fused(), 1u);
  EXPECT_TRUE(original->bad != duplicate->bad) << "exactly one of the two survives";
  const MapPoint* survivor = original->bad ? duplicate : original;
  const MapPoint* merged = original->bad ? original : duplicate;
  EXPECT_EQ(merged->replaced_by, survivor);
  EXPECT_EQ(survivor->observations.size(), 2u);
  EXPECT_EQ(survivor->observations.count(first), 1u);
  EXPECT_EQ(survivor->observations.count(second), 1u);
  for (const auto& [keyframe, feature] : survivor->observations) {
    EXPECT_EQ(keyframe->points[static_cast<std::size_t>(feature)], survivor);
  }
}

// Every keyframe after the first makes a new point for half the scene points it sees, so fusion merges
// over a hundred of them. With three threads the searches run ahead in parallel; the map must be the
// one-thread map, merge for merge, descriptor for descriptor.
TEST(Mapping, ParallelFusionMergesAsOneThreadDoes) {
  SceneSpec spec;
  spec.keyframes = 4;
  const SyntheticScene scene(spec);
  SlamSettings one = test_settings(), three = test_settings();
  one.mapping_threads = 1;
  three.mapping_threads = 3;
  Map map_one, map_three;
  LocalMapper mapper_one(one, map_one), mapper_three(three, map_three);
  for (auto* run : {&mapper_one, &mapper_three}) {
    Map& map = run == &mapper_one ? map_one : map_three;
    TrackingStandIn tracking(scene, map, *run);
    for (std::size_t k = 0; k < scene.true_T_cw.size(); ++k) {
      tracking.insert(k, scene.true_T_cw[k], k == 0 ? -1 : TrackingStandIn::kDuplicateEven);
      run->process_all();
    }
  }
  std::printf("points fused: %llu\n", static_cast<unsigned long long>(mapper_one.points_fused()));
  EXPECT_GT(mapper_one.points_fused(), 100u);
  EXPECT_EQ(mapper_three.points_fused(), mapper_one.points_fused());
  EXPECT_TRUE(MapSnapshot(map_one) == MapSnapshot(map_three));
  std::lock_guard lock_one(map_one.mutex), lock_three(map_three.mutex);
  ASSERT_EQ(map_one.points().size(), map_three.points().size());
  for (std::size_t i = 0; i < map_one.points().size(); ++i) {
    const MapPoint& a = *map_one.points()[i];
    const MapPoint& b = *map_three.points()[i];
    ASSERT_EQ(a.bad, b.bad) << "point " << i;
    EXPECT_EQ(a.descriptor.bytes, b.descriptor.bytes) << "point " << i;
    EXPECT_EQ(a.observations.size(), b.observations.size()) << "point " << i;
    EXPECT_EQ(a.replaced_by == nullptr ? ~0ull : a.replaced_by->id,
              b.replaced_by == nullptr ? ~0ull : b.replaced_by->id) << "point " << i;
  }
}

TEST(Mapping, BundleAdjustmentReducesPoseErrorsAndKeepsKeyframeZeroFixed) {
  SceneSpec spec;
  spec.keyframes = 3;
  const SyntheticScene scene(spec);
  std::vector<SE3> poses = scene.true_T_cw;
  SE3 delta1 = SE3::Identity(), delta2 = SE3::Identity();
  delta1.linear() = Eigen::AngleAxisd(0.008, Eigen::Vector3d(1, 2, 0).normalized()).toRotationMatrix();
  delta1.translation() = Eigen::Vector3d(0.02, -0.015, 0.01);
  delta2.linear() = Eigen::AngleAxisd(0.006, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  delta2.translation() = Eigen::Vector3d(-0.015, 0.01, 0.02);
  poses[1] = delta1 * poses[1];
  poses[2] = delta2 * poses[2];
  Map map;
  LocalMapper mapper(test_settings(), map);
  run_deterministic(scene, poses, map, mapper);

  std::lock_guard lock(map.mutex);
  ASSERT_EQ(map.num_keyframes(), 3u);
  EXPECT_TRUE(map.keyframe_by_id(0)->T_cw.matrix() == scene.true_T_cw[0].matrix()) << "keyframe 0 moved";
  for (std::size_t k = 1; k < 3; ++k) {
    const SE3& refined = map.keyframe_by_id(k)->T_cw;
    const double before_m = center_error_m(poses[k], scene.true_T_cw[k]);
    const double after_m = center_error_m(refined, scene.true_T_cw[k]);
    const double before_rad = rotation_error_rad(poses[k], scene.true_T_cw[k]);
    const double after_rad = rotation_error_rad(refined, scene.true_T_cw[k]);
    std::printf("keyframe %zu: centre error %.4f -> %.4f m, rotation %.5f -> %.5f rad\n", k, before_m,
                after_m, before_rad, after_rad);
    EXPECT_LT(after_m, 0.25 * before_m);
    EXPECT_LT(after_rad, 0.25 * before_rad);
  }
}

TEST(Mapping, CullsARedundantKeyframeButKeepsOneWithPointsOfItsOwn) {
  // Four keyframes 10 cm apart see the same close points; keyframe 2 alone also sees 60 more.
  // Once keyframe 3 is mapped, every point of keyframe 1 is seen by 3 others: it is redundant.
  SceneSpec spec;
  spec.keyframes = 4;
  spec.step_m = 0.1;
  spec.near_points = 100;
  spec.far_points = 0;
  spec.clutter = 0;
  spec.detect_probability = 1.0;
  spec.private_points = 60;
  spec.private_keyframe = 2;
  const SyntheticScene scene(spec);
  Map map;
  LocalMapper mapper(test_settings(), map);
  TrackingStandIn tracking(scene, map, mapper);
  for (std::size_t k = 0; k < 3; ++k) {
    tracking.insert(k, scene.true_T_cw[k]);
    mapper.process_all();
  }
  {
    std::lock_guard lock(map.mutex);
    EXPECT_EQ(map.num_keyframes(), 3u) << "with 3 keyframes no point has 3 other observers";
  }
  tracking.insert(3, scene.true_T_cw[3]);
  mapper.process_all();
  std::lock_guard lock(map.mutex);
  EXPECT_FALSE(map.keyframe_by_id(0)->bad);
  EXPECT_TRUE(map.keyframe_by_id(1)->bad);
  EXPECT_FALSE(map.keyframe_by_id(2)->bad);
  EXPECT_FALSE(map.keyframe_by_id(3)->bad);
  EXPECT_EQ(mapper.keyframes_culled(), 1u);
  for (const MapPoint* point : map.points()) EXPECT_EQ(point->observations.count(map.keyframe_by_id(1)), 0u);
}

TEST(Mapping, TwoDeterministicRunsGiveBitIdenticalMaps) {
  const SyntheticScene scene{SceneSpec{}};
  Map map_a, map_b;
  LocalMapper mapper_a(test_settings(), map_a), mapper_b(test_settings(), map_b);
  run_deterministic(scene, scene.true_T_cw, map_a, mapper_a);
  run_deterministic(scene, scene.true_T_cw, map_b, mapper_b);
  const MapSnapshot a(map_a), b(map_b);
  EXPECT_GT(a.points.size(), 0u);
  EXPECT_TRUE(a == b);
}

// Three mapping threads: triangulation's searches and local BA's loops on the pool (deterministic
// mode always uses it), the same map as one thread.
TEST(Mapping, ParallelMappingGivesTheSameMapAsOneThread) {
  const SyntheticScene scene{SceneSpec{}};
  SlamSettings one = test_settings(), three = test_settings();
  one.mapping_threads = 1;
  three.mapping_threads = 3;
  Map map_one, map_three;
  LocalMapper mapper_one(one, map_one), mapper_three(three, map_three);
  run_deterministic(scene, scene.true_T_cw, map_one, mapper_one);
  run_deterministic(scene, scene.true_T_cw, map_three, mapper_three);
  EXPECT_GT(mapper_one.points_triangulated(), 0u);
  EXPECT_EQ(mapper_three.points_triangulated(), mapper_one.points_triangulated());
  EXPECT_TRUE(MapSnapshot(map_one) == MapSnapshot(map_three));
  const auto spread = [](const LocalMapper& m) {
    int n = 0;
    for (const MappingTimes& t : m.times()) n += t.spread ? 1 : 0;
    return n;
  };
  EXPECT_EQ(spread(mapper_one), 0);
  EXPECT_EQ(spread(mapper_three), static_cast<int>(mapper_three.times().size()));
}

/// Nine keyframes 0.15 m apart: the first still in view of the last.
SyntheticScene nine_keyframe_scene() {
  SceneSpec spec;
  spec.keyframes = 9;
  spec.step_m = 0.15;
  return SyntheticScene{spec};
}

/// The scene's keyframes 0-2 mapped one at a time (the map then has enough keyframes for local
/// BA), then 3-8 queued together and mapped.
void map_three_then_queue_six(const SyntheticScene& scene, Map& map, LocalMapper& mapper) {
  TrackingStandIn tracking(scene, map, mapper);
  for (std::size_t k = 0; k < 3; ++k) {
    tracking.insert(k, scene.true_T_cw[k]);
    mapper.process_all();
  }
  for (std::size_t k = 3; k < 9; ++k) tracking.insert(k, scene.true_T_cw[k]);
  mapper.process_all();
}

// Keyframes queued together: local BA runs only where none waits (the last) by default, and on
// at least every second one with bundle_adjustment_every = 2.
TEST(Mapping, BundleAdjustmentEveryNthKeyframeRunsWhileKeyframesWait) {
  const SyntheticScene scene = nine_keyframe_scene();
  ASSERT_EQ(scene.true_T_cw.size(), 9u);
  for (const int every : {0, 2}) {
    SlamSettings settings = test_settings();
    settings.bundle_adjustment_every = every;
    Map map;
    LocalMapper mapper(settings, map);
    map_three_then_queue_six(scene, map, mapper);
    std::vector<int> ran;
    for (std::size_t k = 3; k < 9; ++k) {
      if (mapper.times()[k].bundle_adjustment_ran) ran.push_back(static_cast<int>(k));
    }
    EXPECT_TRUE(mapper.times()[2].bundle_adjustment_ran);
    const std::vector<int> expected = every == 0 ? std::vector<int>{8} : std::vector<int>{4, 6, 8};
    EXPECT_EQ(ran, expected) << "every " << every;
  }
}

// Keyframes queued together: while others wait, triangulation stops after the first neighbour,
// and with a pool only that neighbour's search is made ahead; the map is one thread's.
TEST(Mapping, KeyframesQueuedTogetherGiveTheSameMapOnAPoolAsOnOneThread) {
  const SyntheticScene scene = nine_keyframe_scene();
  std::vector<MapSnapshot> maps;
  std::vector<std::uint64_t> triangulated;
  for (const int threads : {1, 3}) {
    SlamSettings settings = test_settings();
    settings.mapping_threads = threads;
    Map map;
    LocalMapper mapper(settings, map);
    map_three_then_queue_six(scene, map, mapper);
    ASSERT_EQ(mapper.times().size(), 9u);
    EXPECT_EQ(mapper.times()[3].queued, 5u);
    EXPECT_EQ(mapper.times()[3].spread, threads > 1);
    maps.emplace_back(map);
    triangulated.push_back(mapper.points_triangulated());
  }
  EXPECT_GT(triangulated[0], 0u);
  EXPECT_EQ(triangulated[1], triangulated[0]);
  EXPECT_TRUE(maps[0] == maps[1]);
}

TEST(SlamSettings, BundleAdjustmentEveryIsBounded) {
  SlamSettings settings = test_settings();
  EXPECT_NO_THROW(settings.validate());
  settings.bundle_adjustment_every = -1;
  EXPECT_THROW(settings.validate(), std::invalid_argument);
  settings.bundle_adjustment_every = SlamSettings::kMaxBundleAdjustmentEvery + 1;
  EXPECT_THROW(settings.validate(), std::invalid_argument);
  settings.bundle_adjustment_every = SlamSettings::kMaxBundleAdjustmentEvery;
  EXPECT_NO_THROW(settings.validate());
}

TEST(SlamSettings, RealtimeBundleAdjustmentToleranceIsInTheOpenUnitInterval) {
  SlamSettings settings = test_settings();
  EXPECT_EQ(settings.realtime_bundle_adjustment_tolerance, 1e-3) << "the default";
  for (const double bad : {0.0, 1.0, -0.5, 2.0}) {
    settings.realtime_bundle_adjustment_tolerance = bad;
    EXPECT_THROW(settings.validate(), std::invalid_argument) << bad;
  }
  settings.realtime_bundle_adjustment_tolerance = 1e-6;
  EXPECT_NO_THROW(settings.validate());
}

/// validate() refuses `settings` (whose `field` holds `value`) with a message naming the field.
void expect_rejected_naming(const SlamSettings& settings, const std::string& field, int value) {
  try {
    settings.validate();
    ADD_FAILURE() << field << " = " << value << " was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(SlamSettings, RealtimeBundleAdjustmentStepsAreBounded) {
  SlamSettings settings = test_settings();
  EXPECT_EQ(settings.realtime_bundle_adjustment_steps, 1) << "the default";
  for (const int bad : {-1, SlamSettings::kMaxBundleAdjustmentSteps + 1}) {
    settings.realtime_bundle_adjustment_steps = bad;
    expect_rejected_naming(settings, "realtime_bundle_adjustment_steps", bad);
  }
  for (const int good : {0, SlamSettings::kMaxBundleAdjustmentSteps}) {
    settings.realtime_bundle_adjustment_steps = good;
    EXPECT_NO_THROW(settings.validate()) << good;
  }
}

TEST(SlamSettings, KeyframeQueueLimitIsBounded) {
  SlamSettings settings = test_settings();
  EXPECT_EQ(settings.keyframe_queue_limit, 2) << "the default";
  settings.keyframe_queue_limit = -1;
  EXPECT_THROW(settings.validate(), std::invalid_argument);
  settings.keyframe_queue_limit = SlamSettings::kMaxKeyframeQueueLimit + 1;
  EXPECT_THROW(settings.validate(), std::invalid_argument);
  settings.keyframe_queue_limit = 0;
  EXPECT_NO_THROW(settings.validate());
}

TEST(SlamSettings, MinimumFramesBetweenKeyframesIsWithinTheMaximum) {
  SlamSettings settings = test_settings();
  EXPECT_EQ(settings.min_frames_between_keyframes, 0) << "the default: ORB-SLAM2's for stereo";
  for (const int bad : {-1, settings.max_frames_between_keyframes + 1}) {
    settings.min_frames_between_keyframes = bad;
    expect_rejected_naming(settings, "min_frames_between_keyframes", bad);
  }
  settings.min_frames_between_keyframes = settings.max_frames_between_keyframes;
  EXPECT_NO_THROW(settings.validate());
}

TEST(SlamSettings, ThreadNiceValuesAreNiceValuesAndKeyframesWhileMappingIsOn) {
  SlamSettings settings = test_settings();
  EXPECT_EQ(settings.mapping_thread_nice, 0) << "the default: the caller's";
  EXPECT_EQ(settings.loop_closing_thread_nice, 0) << "the default: the caller's";
  EXPECT_TRUE(settings.keyframes_while_mapping) << "the default";
  for (int* field : {&settings.mapping_thread_nice, &settings.loop_closing_thread_nice}) {
    for (const int bad : {-1, -20, SlamSettings::kMaxNice + 1}) {
      *field = bad;
      EXPECT_THROW(settings.validate(), std::invalid_argument) << bad;
    }
    *field = SlamSettings::kMaxNice;
    EXPECT_NO_THROW(settings.validate());
  }
}

#if defined(__linux__)
/// The nice values of this process's threads, from /proc/self/task/*/stat (field 19).
std::vector<int> thread_nice_values() {
  std::vector<int> out;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
    std::ifstream in(task.path() / "stat");
    std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t close = stat.rfind(')');  // the command name may hold spaces
    if (close == std::string::npos) continue;
    std::istringstream fields(stat.substr(close + 1));
    std::string field;
    for (int k = 3; k <= 19 && fields >> field; ++k) {
      if (k == 19) out.push_back(std::stoi(field));
    }
  }
  return out;
}

/// Starts a thread with `start`, and says whether, while it runs, exactly one thread of this
/// process is at nice `nice`; then `stop`.
template <class Start, class Stop>
::testing::AssertionResult a_thread_runs_at_nice(int nice, Start&& start, Stop&& stop) {
  const std::vector<int> before = thread_nice_values();
  if (std::count(before.begin(), before.end(), nice) != 0) {
    return ::testing::AssertionFailure() << "a thread already runs at nice " << nice;
  }
  start();
  bool found = false;
  for (int tries = 0; tries < 2000 && !found; ++tries) {
    const std::vector<int> now = thread_nice_values();
    found = std::count(now.begin(), now.end(), nice) == 1;
    if (!found) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  stop();
  if (!found) return ::testing::AssertionFailure() << "no thread of this process at nice " << nice;
  return ::testing::AssertionSuccess();
}

/// Skips the calling test when this process already runs at `nice` or above: a thread cannot go
/// below its process's nice value without privileges.
#define PORTA_SKIP_WHEN_NICE_AT_LEAST(nice)                                                        \
  do {                                                                                             \
    const std::vector<int> values = thread_nice_values();                                          \
    ASSERT_FALSE(values.empty());                                                                  \
    const int highest = *std::max_element(values.begin(), values.end());                           \
    if (highest >= (nice)) GTEST_SKIP() << "this process already runs at nice " << highest;        \
  } while (false)

// Realtime, not at idle priority: the mapping thread runs at SlamSettings::mapping_thread_nice,
// the loop-closing thread at loop_closing_thread_nice.
TEST(Mapping, TheMappingAndLoopClosingThreadsRunAtTheirNiceValues) {
  PORTA_SKIP_WHEN_NICE_AT_LEAST(7);
  Map map;
  SlamSettings settings = test_settings();
  settings.mapping_thread_idle_priority = false;
  settings.mapping_thread_nice = 6;
  settings.loop_closing_thread_nice = 7;
  LocalMapper mapper(settings, map);
  EXPECT_TRUE(a_thread_runs_at_nice(6, [&] { mapper.start(); }, [&] { mapper.stop(); }));
  LoopCloser closer(settings, map);
  EXPECT_TRUE(a_thread_runs_at_nice(7, [&] { closer.start(); }, [&] { closer.stop(); }));
}
#endif

/// Waits until the mapping thread has processed everything queued (queue first, then idle: the
/// thread clears idle under the queue lock when it takes a keyframe).
void wait_until_processed(const LocalMapper& mapper) {
  while (mapper.queued_keyframes() > 0 || !mapper.accepts_keyframes()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

TEST(Mapping, RealtimeModeFedOneAtATimeGivesTheDeterministicMap) {
  // True by construction: with nothing else touching the map and each keyframe processed before the
  // next arrives, the thread runs exactly the deterministic sequence of steps, when its local BA
  // runs the deterministic mode's two stages and stops where they do (the realtime defaults, one
  // step after a keyframe that had its BA and a tolerance of 1e-3, stop sooner).
  const SyntheticScene scene{SceneSpec{}};
  Map deterministic_map;
  LocalMapper deterministic(test_settings(), deterministic_map);
  run_deterministic(scene, scene.true_T_cw, deterministic_map, deterministic);

  Map map;
  SlamSettings realtime = test_settings();
  realtime.realtime_bundle_adjustment_tolerance = SlamSettings::kDeterministicBundleAdjustmentTolerance;
  realtime.realtime_bundle_adjustment_steps = 0;
  LocalMapper mapper(realtime, map);
  TrackingStandIn tracking(scene, map, mapper);
  mapper.start();
  EXPECT_THROW(mapper.process_all(), std::logic_error);
  for (std::size_t k = 0; k < scene.true_T_cw.size(); ++k) {
    tracking.insert(k, scene.true_T_cw[k]);
    wait_until_processed(mapper);
  }
  mapper.stop();
  EXPECT_EQ(mapper.times().size(), scene.true_T_cw.size());
  EXPECT_TRUE(MapSnapshot(map) == MapSnapshot(deterministic_map));
}

/// Keyframe poses ~2 cm and ~0.4 degrees off the truth (keyframe 0 exact), so that a local BA has
/// work for more than one step.
std::vector<SE3> perturbed_poses(const SyntheticScene& scene) {
  std::vector<SE3> poses = scene.true_T_cw;
  for (std::size_t k = 1; k < poses.size(); ++k) {
    SE3 delta = SE3::Identity();
    const double s = (k % 2 == 0) ? 1.0 : -1.0;
    delta.linear() = Eigen::AngleAxisd(0.007, Eigen::Vector3d(1.0, s * 2.0, 0.5).normalized()).toRotationMatrix();
    delta.translation() = Eigen::Vector3d(0.02 * s, -0.01, 0.015);
    poses[k] = delta * poses[k];
  }
  return poses;
}

/// The realtime mapper fed one keyframe at a time, each processed before the next.
std::vector<MappingTimes> map_one_at_a_time(const SyntheticScene& scene, const SlamSettings& settings) {
  Map map;
  LocalMapper mapper(settings, map);
  TrackingStandIn tracking(scene, map, mapper);
  const std::vector<SE3> poses = perturbed_poses(scene);
  mapper.start();
  for (std::size_t k = 0; k < poses.size(); ++k) {
    tracking.insert(k, poses[k]);
    wait_until_processed(mapper);
  }
  mapper.stop();
  return mapper.times();
}

// SlamSettings::realtime_bundle_adjustment_steps: a local BA right after the keyframe before had
// its own runs at most that many iterations; the first BA (keyframes 0 and 1 had none: the map was
// too small) and every BA with 0 run ORB-SLAM2's two stages.
TEST(Mapping, RealtimeBundleAdjustmentRightAfterAnotherRunsItsStepsOnly) {
  SceneSpec spec;
  spec.keyframes = 7;
  spec.step_m = 0.2;
  const SyntheticScene scene{spec};
  for (const int steps : {0, 1, 2}) {
    SCOPED_TRACE("steps " + std::to_string(steps));
    SlamSettings settings = test_settings();
    settings.realtime_bundle_adjustment_tolerance = SlamSettings::kDeterministicBundleAdjustmentTolerance;
    settings.realtime_bundle_adjustment_steps = steps;
    const std::vector<MappingTimes> times = map_one_at_a_time(scene, settings);
    ASSERT_EQ(times.size(), 7u);
    EXPECT_FALSE(times[1].bundle_adjustment_ran);
    ASSERT_TRUE(times[2].bundle_adjustment_ran);
    EXPECT_GT(times[2].bundle_adjustment_iterations, 2) << "the first BA: both stages";
    int most = 0;
    for (std::size_t k = 3; k < times.size(); ++k) {
      ASSERT_TRUE(times[k].bundle_adjustment_ran) << k;
      EXPECT_GE(times[k].bundle_adjustment_iterations, 1) << k;
      most = std::max(most, times[k].bundle_adjustment_iterations);
    }
    if (steps == 0) {
      EXPECT_GT(most, 2) << "ORB-SLAM2's stages every time";
    } else {
      EXPECT_LE(most, steps);
    }
  }
}

// The deterministic mode is the accuracy reference: it always runs the two stages.
TEST(Mapping, DeterministicModeIgnoresTheRealtimeBundleAdjustmentSteps) {
  const SyntheticScene scene{SceneSpec{}};
  const std::vector<SE3> poses = perturbed_poses(scene);
  SlamSettings one_step = test_settings(), two_stages = test_settings();
  one_step.realtime_bundle_adjustment_steps = 1;
  two_stages.realtime_bundle_adjustment_steps = 0;
  Map a, b;
  LocalMapper mapper_a(one_step, a), mapper_b(two_stages, b);
  run_deterministic(scene, poses, a, mapper_a);
  run_deterministic(scene, poses, b, mapper_b);
  EXPECT_TRUE(MapSnapshot(a) == MapSnapshot(b));
  int most = 0;
  for (const MappingTimes& t : mapper_a.times()) most = std::max(most, t.bundle_adjustment_iterations);
  EXPECT_GT(most, 1);
}

TEST(Mapping, StopProcessesEveryQueuedKeyframe) {
  const SyntheticScene scene{SceneSpec{}};
  Map map;
  LocalMapper mapper(test_settings(), map);
  TrackingStandIn tracking(scene, map, mapper);
  mapper.start();
  for (std::size_t k = 0; k < scene.true_T_cw.size(); ++k) tracking.insert(k, scene.true_T_cw[k]);
  mapper.stop();
  EXPECT_EQ(mapper.queued_keyframes(), 0u);
  EXPECT_EQ(mapper.times().size(), scene.true_T_cw.size());
  EXPECT_TRUE(mapper.accepts_keyframes());
  std::lock_guard lock(map.mutex);
  EXPECT_GT(map.num_points(), 0u);
}

// Tracking's wait for mapping (SlamSettings::keyframe_queue_limit): it returns once the thread
// has taken keyframes off the queue until fewer than the limit wait, and at once without a thread.
TEST(Mapping, WaitWhileQueuedReturnsOnceTheMapperTakesKeyframes) {
  const SyntheticScene scene{SceneSpec{}};
  ASSERT_GE(scene.true_T_cw.size(), 4u);
  Map map;
  LocalMapper mapper(test_settings(), map);
  TrackingStandIn tracking(scene, map, mapper);
  tracking.insert(0, scene.true_T_cw[0]);
  mapper.wait_while_queued(1);  // no thread: nothing would ever dequeue, so no wait
  EXPECT_EQ(mapper.queued_keyframes(), 1u);

  mapper.start();
  for (std::size_t k = 1; k < 4; ++k) tracking.insert(k, scene.true_T_cw[k]);
  std::size_t queued_at_return = 99;
  std::thread waiter([&] {
    mapper.wait_while_queued(1);
    queued_at_return = mapper.queued_keyframes();  // nothing is inserted meanwhile: it only shrinks
  });
  waiter.join();
  EXPECT_EQ(queued_at_return, 0u) << "returned while keyframes still waited";
  mapper.stop();
  EXPECT_EQ(mapper.times().size(), 4u);
}

TEST(Mapping, RealtimeMapperPausesWhileAFrameIsTrackedThenFinishes) {
  const SyntheticScene scene{SceneSpec{}};
  ASSERT_GE(scene.true_T_cw.size(), 3u);
  Map map;
  const SlamSettings settings = test_settings();
  ASSERT_TRUE(settings.mapping_yields_to_tracking);
  LocalMapper mapper(settings, map);
  TrackingStandIn tracking(scene, map, mapper);
  mapper.start();
  tracking.insert(0, scene.true_T_cw[0]);
  wait_until_processed(mapper);

  // A frame is being tracked: the mapper takes keyframe 1 off the queue and stops at its first
  // pause point, since nothing else waits.
  mapper.tracking_started();
  tracking.insert(1, scene.true_T_cw[1]);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(mapper.queued_keyframes(), 0u);
  EXPECT_FALSE(mapper.accepts_keyframes()) << "the mapper finished a keyframe while a frame was tracked";

  // The frame is done: the mapper goes on.
  mapper.tracking_finished();
  wait_until_processed(mapper);

  // Keyframes waiting: the mapper does not pause (it is behind), and stop() does not hang on a
  // pause point even while a frame is still marked as tracked.
  mapper.tracking_started();
  for (std::size_t k = 2; k < scene.true_T_cw.size(); ++k) tracking.insert(k, scene.true_T_cw[k]);
  mapper.stop();
  mapper.tracking_finished();
  EXPECT_EQ(mapper.queued_keyframes(), 0u);
  EXPECT_EQ(mapper.times().size(), scene.true_T_cw.size());
}

}  // namespace
}  // namespace porta::slam::mapping_test
#endif  // PORTA_SLAM_BUILT
