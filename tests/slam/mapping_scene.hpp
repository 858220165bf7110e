// A synthetic scene for the local-mapping tests: 3-D points with random descriptors seen by a row
// of stereo keyframes, made directly as FrameFeatures (no images), and a stand-in for tracking
// that links the close stereo points as the tracker does and leaves the rest unmatched.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <vector>

#include "porta/slam/local_mapper.hpp"
#include "porta/slam/map.hpp"

namespace porta::slam::mapping_test {

inline const StereoCamera kCamera{640, 480, 500.0, 500.0, 320.0, 240.0, 0.1};  // bf = 50 px m

inline SlamSettings test_settings() {
  SlamSettings settings;
  settings.camera = kCamera;  // close stereo points: depth < 35 * 0.1 = 3.5 m
  return settings;
}

struct SceneSpec {
  int near_points = 150;  ///< stereo, depth 1.5 - 3 m (close): tracking links them
  int far_points = 150;   ///< mono (no stereo match), depth 4 - 7 m: local mapping triangulates them
  int keyframes = 5;
  double step_m = 0.3;              ///< camera motion along x between keyframes
  double detect_probability = 0.8;  ///< each keyframe detects a random subset of the visible points
  double noise_px = 0.15;           ///< keypoint noise at level 0 (times the level's scale)
  int clutter = 30;                 ///< features of no point, per keyframe
  int private_points = 0;           ///< near points detected only by keyframe `private_keyframe`
  int private_keyframe = -1;
  unsigned seed = 7;
};

struct ScenePoint {
  Eigen::Vector3d position;
  Descriptor descriptor;
  int level = 0;
  float angle_rad = 0.0f;
  bool near = true;
  int only_keyframe = -1;  ///< >= 0: detected by that keyframe alone
};

class SyntheticScene {
 public:
  explicit SyntheticScene(const SceneSpec& spec) : spec_(spec), rng_(spec.seed) {
    const double span = spec.step_m * (spec.keyframes - 1);
    for (int i = 0; i < spec.near_points + spec.private_points; ++i) {
      ScenePoint p = random_point(uniform(-0.5, 0.5 + span), uniform(-0.5, 0.5), uniform(1.5, 3.0));
      if (i >= spec.near_points) p.only_keyframe = spec.private_keyframe;
      points.push_back(p);
    }
    for (int i = 0; i < spec.far_points; ++i) {
      ScenePoint p = random_point(uniform(-1.5, 1.5 + span), uniform(-1.2, 1.2), uniform(4.0, 7.0));
      p.near = false;
      points.push_back(p);
    }
    for (int k = 0; k < spec.keyframes; ++k) {
      SE3 T_wc = SE3::Identity();
      T_wc.linear() =
          Eigen::AngleAxisd(0.03 * std::sin(1.3 * k), Eigen::Vector3d::UnitY()).toRotationMatrix();
      T_wc.translation() = Eigen::Vector3d(spec.step_m * k, 0.02 * std::sin(0.7 * k), 0.01 * k);
      true_T_cw.push_back(T_wc.inverse());
      make_features(k);
    }
  }

  std::vector<ScenePoint> points;
  std::vector<SE3> true_T_cw;
  std::vector<std::shared_ptr<const FrameFeatures>> features;
  std::vector<std::vector<int>> truth;  ///< per keyframe, per feature: the scene point, -1 clutter

 private:
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  double gauss(double sigma) { return std::normal_distribution<double>(0.0, sigma)(rng_); }

  ScenePoint random_point(double x, double y, double z) {
    ScenePoint p;
    p.position = {x, y, z};
    for (auto& byte : p.descriptor.bytes) byte = static_cast<std::uint8_t>(rng_() & 0xffu);
    p.level = static_cast<int>(rng_() % 3);
    p.angle_rad = static_cast<float>(uniform(0.0, 6.28));
    return p;
  }

  Descriptor observed_descriptor(const Descriptor& d) {
    Descriptor out = d;
    const int flips = static_cast<int>(rng_() % 5);
    for (int f = 0; f < flips; ++f) {
      const unsigned bit = static_cast<unsigned>(rng_() % 256);
      out.bytes[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
    return out;
  }

  void make_features(int k) {
    const ScalePyramid pyramid(8, 1.2);
    auto f = std::make_shared<FrameFeatures>();
    std::vector<int> ids;
    auto push = [&](double u, double v, int level, float angle, const Descriptor& d, double u_right) {
      f->uv.emplace_back(static_cast<float>(u), static_cast<float>(v));
      f->level.push_back(static_cast<std::uint8_t>(level));
      f->angle_rad.push_back(angle);
      f->descriptors.push_back(d);
      f->u_right.push_back(static_cast<float>(u_right));
      f->depth_m.push_back(u_right >= 0.0 ? static_cast<float>(kCamera.bf() / (u - u_right)) : -1.0f);
    };
    for (std::size_t j = 0; j < points.size(); ++j) {
      const ScenePoint& p = points[j];
      const Eigen::Vector3d c = true_T_cw[static_cast<std::size_t>(k)] * p.position;
      if (c.z() < 0.5) continue;
      const double u = kCamera.fx * c.x() / c.z() + kCamera.cx;
      const double v = kCamera.fy * c.y() / c.z() + kCamera.cy;
      if (u < 5.0 || u > kCamera.width - 5.0 || v < 5.0 || v > kCamera.height - 5.0) continue;
      if (p.only_keyframe >= 0 ? p.only_keyframe != k : uniform(0.0, 1.0) > spec_.detect_probability)
        continue;
      const double sigma = spec_.noise_px * pyramid.scale[static_cast<std::size_t>(p.level)];
      const double u_noisy = u + gauss(sigma);
      const double u_right = p.near ? u - kCamera.bf() / c.z() + gauss(sigma) : -1.0;
      push(u_noisy, v + gauss(sigma), p.level, p.angle_rad, observed_descriptor(p.descriptor), u_right);
      ids.push_back(static_cast<int>(j));
    }
    for (int c = 0; c < spec_.clutter; ++c) {
      Descriptor d;
      for (auto& byte : d.bytes) byte = static_cast<std::uint8_t>(rng_() & 0xffu);
      push(uniform(5.0, 635.0), uniform(5.0, 475.0), static_cast<int>(rng_() % 3), 0.0f, d, -1.0);
      ids.push_back(-1);
    }
    features.push_back(f);
    truth.push_back(ids);
  }

  SceneSpec spec_;
  std::mt19937 rng_;
};

/// Stands in for tracking: makes the keyframe, links the close stereo features to the map point
/// already made for their scene point (or makes one from the stereo depth, as the tracker does for
/// new keyframes) and queues the keyframe. Far (mono) features stay unmatched.
class TrackingStandIn {
 public:
  TrackingStandIn(const SyntheticScene& scene, Map& map, LocalMapper& mapper)
      : scene_(scene), map_(map), mapper_(mapper) {}

  /// For insert()'s `duplicate`: every scene point of even index gets a new map point (the others
  /// keep the keyframe covisible with those before it).
  static constexpr int kDuplicateEven = -2;

  /// `duplicate`: a scene point that gets a second, new map point instead of the existing one (or
  /// kDuplicateEven).
  KeyFrame* insert(std::size_t k, const SE3& T_cw, int duplicate = -1) {
    KeyFrame* keyframe = nullptr;
    {
      std::lock_guard lock(map_.mutex);
      Frame frame(k, 0.1 * static_cast<double>(k), scene_.features[k], kCamera);
      frame.T_cw = T_cw;
      frame.has_pose = true;
      keyframe = map_.add_keyframe(frame);
      const FrameFeatures& f = *scene_.features[k];
      for (std::size_t i = 0; i < f.size(); ++i) {
        const int j = scene_.truth[k][i];
        if (j < 0 || !f.has_depth(i) || f.depth_m[i] > test_settings().close_depth_m()) continue;
        MapPoint* point = resolve(j);
        if (point == nullptr || j == duplicate || (duplicate == kDuplicateEven && j % 2 == 0)) {
          point = map_.add_point(frame.unproject_stereo(i, kCamera), keyframe, frame.id);
          known_[j] = point;
        }
        Map::add_observation(point, keyframe, static_cast<int>(i));
      }
    }
    mapper_.insert_keyframe(keyframe);
    return keyframe;
  }

  /// The good map point standing for scene point `j`, following merges; nullptr if none.
  MapPoint* resolve(int j) const {
    const auto it = known_.find(j);
    if (it == known_.end()) return nullptr;
    MapPoint* point = it->second;
    while (point->bad && point->replaced_by != nullptr) point = point->replaced_by;
    return point->bad ? nullptr : point;
  }

 private:
  const SyntheticScene& scene_;
  Map& map_;
  LocalMapper& mapper_;
  std::map<int, MapPoint*> known_;
};

/// Every good point's position and every keyframe's pose and state, by id: equal snapshots mean
/// bit-identical maps.
struct MapSnapshot {
  std::vector<std::pair<std::uint64_t, Eigen::Vector3d>> points;
  std::vector<std::pair<std::uint64_t, Eigen::Matrix4d>> poses;
  std::vector<bool> keyframe_bad;

  explicit MapSnapshot(const Map& map) {
    std::lock_guard lock(map.mutex);
    for (const MapPoint* p : map.points()) points.emplace_back(p->id, p->position);
    for (std::uint64_t id = 0; map.keyframe_by_id(id) != nullptr; ++id) {
      const KeyFrame* kf = map.keyframe_by_id(id);
      poses.emplace_back(id, kf->T_cw.matrix());
      keyframe_bad.push_back(kf->bad);
    }
  }
  bool operator==(const MapSnapshot& other) const {
    return points == other.points && poses == other.poses && keyframe_bad == other.keyframe_bad;
  }
};

}  // namespace porta::slam::mapping_test
