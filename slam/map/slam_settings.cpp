#include "porta/slam/slam_settings.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>

namespace porta::slam {

int default_cell_size(int width, int height) {
  // 594 level-0 cells: what 28-px cells give a 1242x375 KITTI image. 32-px cells (455) tracked
  // with a rotation error 1.13x that of 28-px ones as fast as possible (docs/BENCHMARKS.md).
  constexpr double kKittiCells = 1242.0 * 375.0 / (28.0 * 28.0);
  const double area = static_cast<double>(std::max(width, 1)) * static_cast<double>(std::max(height, 1));
  return std::clamp(static_cast<int>(std::lround(std::sqrt(area / kKittiCells))), 8, 32);
}

SlamSettings default_settings(const StereoCamera& camera) {
  SlamSettings settings;
  settings.camera = camera;
  settings.frontend.cell_width = settings.frontend.cell_height = default_cell_size(camera.width, camera.height);
  const int max_disparity = static_cast<int>(std::ceil(camera.bf() / 0.5));
  settings.frontend.stereo_max_disparity =
      std::clamp(max_disparity, settings.frontend.stereo_min_disparity + 1, std::min(camera.width, 4096));
  return settings;
}

void SlamSettings::validate() const {
  camera.validate();
  frontend.validate();
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("SLAM settings: " + what);
  };
  require(std::isfinite(th_depth) && th_depth > 0.0, "th_depth (ThDepth) must be > 0, got " + std::to_string(th_depth));
  require(min_init_stereo_points >= 10 && min_init_stereo_points <= 100000,
          "min_init_stereo_points must be in [10, 100000], got " + std::to_string(min_init_stereo_points));
  require(std::isfinite(min_disparity_px) && min_disparity_px > 0.0,
          "min_disparity_px must be > 0, got " + std::to_string(min_disparity_px));
  require(min_tracked_inliers >= 3, "min_tracked_inliers must be >= 3, got " + std::to_string(min_tracked_inliers));
  require(max_frames_between_keyframes >= 1,
          "max_frames_between_keyframes must be >= 1, got " + std::to_string(max_frames_between_keyframes));
  require(min_frames_between_keyframes >= 0 && min_frames_between_keyframes <= max_frames_between_keyframes,
          "min_frames_between_keyframes must be in [0, max_frames_between_keyframes = " +
              std::to_string(max_frames_between_keyframes) + "], got " + std::to_string(min_frames_between_keyframes));
  require(mapping_threads >= 0 && mapping_threads <= kMaxMappingThreads,
          "mapping_threads must be in [0, " + std::to_string(kMaxMappingThreads) + "] (0 = by the machine), got " +
              std::to_string(mapping_threads));
  require(mapping_thread_nice >= 0 && mapping_thread_nice <= kMaxNice,
          "mapping_thread_nice must be in [0, " + std::to_string(kMaxNice) + "], got " +
              std::to_string(mapping_thread_nice));
  require(loop_closing_thread_nice >= 0 && loop_closing_thread_nice <= kMaxNice,
          "loop_closing_thread_nice must be in [0, " + std::to_string(kMaxNice) + "], got " +
              std::to_string(loop_closing_thread_nice));
  require(keyframe_queue_limit >= 0 && keyframe_queue_limit <= kMaxKeyframeQueueLimit,
          "keyframe_queue_limit must be in [0, " + std::to_string(kMaxKeyframeQueueLimit) +
              "] (0 = tracking never waits for mapping), got " + std::to_string(keyframe_queue_limit));
  require(bundle_adjustment_every >= 0 && bundle_adjustment_every <= kMaxBundleAdjustmentEvery,
          "bundle_adjustment_every must be in [0, " + std::to_string(kMaxBundleAdjustmentEvery) +
              "] (0 = only when no keyframe waits), got " + std::to_string(bundle_adjustment_every));
  require(realtime_bundle_adjustment_tolerance > 0.0 && realtime_bundle_adjustment_tolerance < 1.0,
          "realtime_bundle_adjustment_tolerance must be in (0, 1), got " +
              std::to_string(realtime_bundle_adjustment_tolerance));
  require(realtime_bundle_adjustment_steps >= 0 && realtime_bundle_adjustment_steps <= kMaxBundleAdjustmentSteps,
          "realtime_bundle_adjustment_steps must be in [0, " + std::to_string(kMaxBundleAdjustmentSteps) +
              "] (0 = ORB-SLAM2's two stages always), got " + std::to_string(realtime_bundle_adjustment_steps));
  place_recognition.validate();
}

int SlamSettings::resolved_mapping_threads() const {
  if (mapping_threads > 0) return mapping_threads;
  const int hardware = static_cast<int>(std::thread::hardware_concurrency());
  return hardware >= 8 ? std::min(8, hardware / 2) : 1;
}

}  // namespace porta::slam
