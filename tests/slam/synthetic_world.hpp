// A synthetic world for SLAM tests without images: random 3-D points with random descriptors and
// appearance, a camera path with exact ground truth, and per frame the features a frontend would
// report (level-n integer keypoints, noisy descriptors, stereo depth, random clutter); and the
// deterministic pipeline (tracking, local mapping, optionally loop closing) that the tests drive.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include "porta/registry.hpp"
#include "porta/slam/local_mapper.hpp"
#include "porta/slam/loop_closer.hpp"
#include "porta/slam/map.hpp"
#include "porta/slam/tracker.hpp"
#include "porta/tables.hpp"

namespace porta::slam::test {

/// A straight drive of `poses` T_cw: `step_m` forward and `step_deg` of yaw per frame.
inline std::vector<SE3> straight_path(int poses, double step_m = 0.3, double step_deg = 1.0) {
  SE3 step = SE3::Identity();
  step.linear() =
      Eigen::AngleAxisd(step_deg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  step.translation() = Eigen::Vector3d(0.0, 0.0, step_m);
  std::vector<SE3> path;
  SE3 T_wc = SE3::Identity();
  for (int k = 0; k < poses; ++k) {
    path.push_back(T_wc.inverse());
    T_wc = T_wc * step;
  }
  return path;
}

inline Descriptor random_descriptor(std::mt19937_64& rng) {
  Descriptor d;
  for (std::size_t i = 0; i < d.bytes.size(); i += 8) {
    const std::uint64_t word = rng();
    for (std::size_t k = 0; k < 8; ++k) d.bytes[i + k] = static_cast<std::uint8_t>(word >> (8 * k));
  }
  return d;
}

/// Points, their descriptors and appearance, and the true camera path (camera 0 = world).
struct World {
  StereoCamera camera{640, 480, 500.0, 500.0, 320.0, 240.0, 0.12};
  SlamSettings settings;
  FrontendTables tables;
  std::vector<Eigen::Vector3d> points;
  std::vector<Descriptor> descriptors;
  std::vector<double> level0_distance_m;  ///< distance at which the point is detected on level 0
  std::vector<int> angle_bin;
  std::vector<SE3> T_cw;  ///< truth
  std::vector<int> host_frame;  ///< per point: the frame it was placed in front of

  /// `path`: the true T_cw of every frame; points are placed in front of the first `point_frames`.
  World(std::vector<SE3> path, std::uint64_t seed, int num_points, int point_frames, double max_depth_m = 30.0)
      : T_cw(std::move(path)) {
    settings.camera = camera;
    settings.min_init_stereo_points = 300;
    tables.settings = settings.frontend;
    tables.scales_q16 = build_level_scales_q16(settings.frontend.levels, settings.frontend.scale_factor);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int j = 0; j < num_points; ++j) {
      // In front of a random camera of the path, anywhere in its image, 1.5-30 m deep.
      const int k = static_cast<int>(rng() % static_cast<std::uint64_t>(point_frames));
      const double z = 1.5 + (max_depth_m - 1.5) * unit(rng);
      const double u = camera.width * unit(rng), v = camera.height * unit(rng);
      const Eigen::Vector3d in_camera((u - camera.cx) * z / camera.fx, (v - camera.cy) * z / camera.fy, z);
      points.push_back(T_cw[static_cast<std::size_t>(k)].inverse() * in_camera);
      host_frame.push_back(k);
      descriptors.push_back(random_descriptor(rng));
      level0_distance_m.push_back(2.0 + 10.0 * unit(rng));  // most detections on the finer levels
      angle_bin.push_back(static_cast<int>(rng() % 32));
    }
  }
};

struct Feature {
  Keypoint kp;
  Eigen::Vector2f uv;
  Descriptor descriptor;
  float u_right = -1.0f, depth_m = -1.0f;
};

inline Feature make_feature(const World& w, double u, double v, int level) {
  Feature f;
  const std::int32_t s = w.tables.scales_q16[static_cast<std::size_t>(level)];
  f.kp.x = static_cast<std::uint16_t>(std::max(0L, std::lround(u * 65536.0 / s)));
  f.kp.y = static_cast<std::uint16_t>(std::max(0L, std::lround(v * 65536.0 / s)));
  f.kp.level = static_cast<std::uint8_t>(level);
  f.kp.response = 100;
  // The level-0 position as FrameFeatures::from_frontend computes it.
  f.uv =
      Eigen::Vector2f(static_cast<float>(f.kp.x * (s / 65536.0)), static_cast<float>(f.kp.y * (s / 65536.0)));
  return f;
}

inline void set_stereo(const World& w, Feature& f, double disparity) {
  if (disparity < w.settings.min_disparity_px || f.uv.x() - disparity < 0.0) return;
  f.u_right = static_cast<float>(f.uv.x() - disparity);
  f.depth_m = static_cast<float>(w.camera.bf() / disparity);
}

/// What a frontend would report for frame k (clutter_only: no world point at all).
inline std::shared_ptr<const FrameFeatures> observe(const World& w, int k, std::uint64_t seed,
                                                    bool clutter_only = false) {
  std::mt19937_64 rng(seed * 1000003u + static_cast<std::uint64_t>(k));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> pixel_noise(0.0, 0.3);
  const int top = w.settings.frontend.levels - 1;
  std::vector<Feature> features;
  const SE3& T_cw = w.T_cw[static_cast<std::size_t>(k)];
  for (std::size_t j = 0; !clutter_only && j < w.points.size(); ++j) {
    const Eigen::Vector3d pc = T_cw * w.points[j];
    if (pc.z() < 0.5) continue;
    const double u = w.camera.fx * pc.x() / pc.z() + w.camera.cx + pixel_noise(rng);
    const double v = w.camera.fy * pc.y() / pc.z() + w.camera.cy + pixel_noise(rng);
    if (u < 0.0 || v < 0.0 || u >= w.camera.width - 1 || v >= w.camera.height - 1) continue;
    if (unit(rng) < 0.1) continue;  // not detected this time
    const double ratio = w.level0_distance_m[j] / pc.norm();
    const int level = std::clamp(static_cast<int>(std::lround(std::log(ratio) / std::log(1.2))), 0, top);
    Feature f = make_feature(w, u, v, level);
    f.descriptor = w.descriptors[j];
    for (int flips = static_cast<int>(rng() % 7); flips > 0; --flips) {
      const int bit = static_cast<int>(rng() % 256);
      f.descriptor.bytes[static_cast<std::size_t>(bit / 8)] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
    int bin = w.angle_bin[j] + (unit(rng) < 0.1 ? 1 : 0);
    f.kp.angle_bin = static_cast<std::uint8_t>(bin % 32);
    if (unit(rng) < 0.9) set_stereo(w, f, w.camera.bf() / pc.z() + 0.05 * pixel_noise(rng));
    features.push_back(f);
  }
  const int clutter = clutter_only ? 800 : 150;
  for (int c = 0; c < clutter; ++c) {
    Feature f = make_feature(w, (w.camera.width - 1) * unit(rng), (w.camera.height - 1) * unit(rng),
                             static_cast<int>(rng() % static_cast<std::uint64_t>(top + 1)));
    f.descriptor = random_descriptor(rng);
    f.kp.angle_bin = static_cast<std::uint8_t>(rng() % 32);
    if (unit(rng) < 0.5) set_stereo(w, f, w.camera.bf() / (2.0 + 28.0 * unit(rng)));
    features.push_back(f);
  }
  // The frontend's canonical order: level, then position.
  std::stable_sort(features.begin(), features.end(), [](const Feature& a, const Feature& b) {
    if (a.kp.level != b.kp.level) return a.kp.level < b.kp.level;
    return a.kp.y != b.kp.y ? a.kp.y < b.kp.y : a.kp.x < b.kp.x;
  });
  auto out = std::make_shared<FrameFeatures>();
  for (const Feature& f : features) {
    out->keypoints.push_back(f.kp);
    out->uv.push_back(f.uv);
    out->level.push_back(f.kp.level);
    out->angle_rad.push_back(static_cast<float>(2.0 * std::numbers::pi * f.kp.angle_bin / 32.0));
    out->descriptors.push_back(f.descriptor);
    out->u_right.push_back(f.u_right);
    out->depth_m.push_back(f.depth_m);
  }
  return out;
}

inline std::unique_ptr<Backend> cpu_backend() {
  BackendOptions options;
  options.threads = 2;
  return BackendRegistry::instance().create("cpu", options);
}

/// A map, local mapping and tracking, run as the deterministic pipeline runs them.
struct Pipeline {
  Map map;
  std::unique_ptr<Backend> backend = cpu_backend();
  LocalMapper mapper;
  std::unique_ptr<LoopCloser> loop_closer;  ///< null: no loop closing, no relocalisation
  Tracker tracker;
  std::vector<TrackingResult> results;
  std::vector<std::vector<std::int64_t>> matched_ids;  ///< per frame, per feature: point id or -1

  Pipeline(const World& w, const SlamSettings& settings, bool with_loop_closer = false)
      : mapper(settings, map),
        loop_closer(with_loop_closer ? std::make_unique<LoopCloser>(settings, map) : nullptr),
        tracker(settings, map, mapper, *backend, w.tables, loop_closer.get()) {
    if (loop_closer) mapper.set_keyframe_processed([this](KeyFrame* k) { loop_closer->insert_keyframe(k); });
  }

  const TrackingResult& feed(std::uint64_t id, std::shared_ptr<const FrameFeatures> features) {
    results.push_back(tracker.track(id, 0.1 * static_cast<double>(id), std::move(features)));
    if (results.back().keyframe_inserted) {
      mapper.process_all();
      if (loop_closer) loop_closer->process_all();
    }
    std::vector<std::int64_t> ids;
    for (const MapPoint* p : tracker.last_frame().points)
      ids.push_back(p ? static_cast<std::int64_t>(p->id) : -1);
    matched_ids.push_back(std::move(ids));
    return results.back();
  }
  void run(const World& w, int frames, std::uint64_t seed) {
    for (int k = 0; k < frames; ++k) feed(static_cast<std::uint64_t>(k), observe(w, k, seed));
  }
};

}  // namespace porta::slam::test
