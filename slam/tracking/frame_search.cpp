// Tracking's projection searches and pose-only optimisation; see frame_search.hpp.
#include "frame_search.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "porta/slam/optim/chi2.hpp"
#include "porta/slam/optim/pose_optimization.hpp"

namespace porta::slam::tracking {
namespace {

/// Where a world point appears in a frame; false when behind the camera or outside the image.
struct Projection {
  Eigen::Vector3d in_camera;
  double u = 0.0, v = 0.0;
};
bool project(const Eigen::Vector3d& world, const SE3& T_cw, const StereoCamera& camera, Projection& out) {
  out.in_camera = T_cw * world;
  const double z = out.in_camera.z();
  if (!(z > 0.0)) return false;
  out.u = camera.fx * out.in_camera.x() / z + camera.cx;
  out.v = camera.fy * out.in_camera.y() / z + camera.cy;
  return out.u >= 0.0 && out.u < camera.width && out.v >= 0.0 && out.v < camera.height;
}

/// Orientation consistency (ORB-SLAM2's rotation histogram): matches vote with the change of their
/// keypoint angle; only those in the three most populated bins are kept (the second and third only
/// when they hold at least a tenth of the first).
class RotationHistogram {
 public:
  void add(float angle_from_rad, float angle_to_rad, int feature) {
    constexpr double kTwoPi = 2.0 * std::numbers::pi;
    double change = static_cast<double>(angle_from_rad) - static_cast<double>(angle_to_rad);
    change -= kTwoPi * std::floor(change / kTwoPi);
    int bin = static_cast<int>(std::lround(change * kRotationBins / kTwoPi));
    if (bin >= kRotationBins) bin = 0;
    bins_[static_cast<std::size_t>(bin)].push_back(feature);
  }
  /// Removes the inconsistent matches from `points`; returns how many were removed.
  int reject_inconsistent(std::vector<MapPoint*>& points) const {
    std::array<int, kRotationBins> order{};
    for (int b = 0; b < kRotationBins; ++b) order[static_cast<std::size_t>(b)] = b;
    // Most populated first; ties to the lower bin, so the choice never depends on anything else.
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return bins_[static_cast<std::size_t>(a)].size() > bins_[static_cast<std::size_t>(b)].size();
    });
    const std::size_t top = bins_[static_cast<std::size_t>(order[0])].size();
    std::array<bool, kRotationBins> keep{};
    keep[static_cast<std::size_t>(order[0])] = true;
    for (int k = 1; k < 3; ++k) {
      const std::size_t count = bins_[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])].size();
      if (static_cast<double>(count) < 0.1 * static_cast<double>(top)) break;
      keep[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])] = true;
    }
    int removed = 0;
    for (int b = 0; b < kRotationBins; ++b) {
      if (keep[static_cast<std::size_t>(b)]) continue;
      for (const int feature : bins_[static_cast<std::size_t>(b)]) {
        points[static_cast<std::size_t>(feature)] = nullptr;
        ++removed;
      }
    }
    return removed;
  }

 private:
  std::array<std::vector<int>, kRotationBins> bins_;
};

bool already_matched(const Frame& frame, int feature) {
  const MapPoint* p = frame.points[static_cast<std::size_t>(feature)];
  return p != nullptr && !p->observations.empty();
}

}  // namespace

int search_last_frame(Frame& current, const Frame& last, double th_px, const SearchGeometry& geometry) {
  const StereoCamera& camera = geometry.camera;
  const FrameFeatures& features = *current.features;
  const FrameFeatures& last_features = *last.features;
  const int top_level = geometry.pyramid.levels - 1;
  // Where the current camera is in the last camera's frame: moving forward by more than the
  // baseline makes points look larger (found on finer-scale = higher levels), backward smaller.
  const Eigen::Vector3d center_in_last = last.T_cw * current.center();
  const bool forward = center_in_last.z() > camera.baseline_m;
  const bool backward = -center_in_last.z() > camera.baseline_m;

  RotationHistogram histogram;
  int matches = 0;
  std::vector<int> candidates;
  for (std::size_t i = 0; i < last_features.size(); ++i) {
    MapPoint* point = last.points[i];
    if (point == nullptr || last.outlier[i] || point->bad) continue;
    Projection p;
    if (!project(point->position, current.T_cw, camera, p)) continue;
    const int last_level = last_features.level[i];
    const double radius = th_px * geometry.pyramid.scale[static_cast<std::size_t>(last_level)];
    int min_level = std::max(0, last_level - 1), max_level = std::min(top_level, last_level + 1);
    if (forward) {
      min_level = last_level;
      max_level = top_level;
    } else if (backward) {
      min_level = 0;
      max_level = last_level;
    }
    current.grid.in_area(features, static_cast<float>(p.u), static_cast<float>(p.v), static_cast<float>(radius),
                         min_level, max_level, candidates);
    const double u_right = p.u - camera.bf() / p.in_camera.z();
    int best = -1, best_distance = 256;
    for (const int c : candidates) {
      if (already_matched(current, c)) continue;
      if (features.has_depth(static_cast<std::size_t>(c)) &&
          std::abs(u_right - features.u_right[static_cast<std::size_t>(c)]) > radius) {
        continue;
      }
      const int distance =
          hamming_distance(point->descriptor, features.descriptors[static_cast<std::size_t>(c)]);
      if (distance < best_distance) {
        best_distance = distance;
        best = c;
      }
    }
    if (best < 0 || best_distance > kMaxDistanceHigh) continue;
    current.points[static_cast<std::size_t>(best)] = point;
    ++matches;
    histogram.add(last_features.angle_rad[i], features.angle_rad[static_cast<std::size_t>(best)], best);
  }
  return matches - histogram.reject_inconsistent(current.points);
}

int search_keyframe(Frame& current, const KeyFrame& keyframe, double th_px, const SearchGeometry& geometry) {
  const FrameFeatures& features = *current.features;
  const FrameFeatures& kf_features = *keyframe.features;
  const Eigen::Vector3d center = current.center();
  const int top_level = geometry.pyramid.levels - 1;
  RotationHistogram histogram;
  int matches = 0;
  std::vector<int> candidates;
  for (std::size_t i = 0; i < kf_features.size(); ++i) {
    MapPoint* point = keyframe.points[i];
    if (point == nullptr || point->bad) continue;
    Projection p;
    if (!project(point->position, current.T_cw, geometry.camera, p)) continue;
    const int level = point->predict_level((point->position - center).norm(), geometry.pyramid);
    const double radius = th_px * geometry.pyramid.scale[static_cast<std::size_t>(level)];
    current.grid.in_area(features, static_cast<float>(p.u), static_cast<float>(p.v), static_cast<float>(radius),
                         std::max(0, level - 1), std::min(top_level, level + 1), candidates);
    int best = -1, best_distance = 256, second_distance = 256;
    for (const int c : candidates) {
      if (current.points[static_cast<std::size_t>(c)] != nullptr) continue;
      const int distance =
          hamming_distance(point->descriptor, features.descriptors[static_cast<std::size_t>(c)]);
      if (distance < best_distance) {
        second_distance = best_distance;
        best_distance = distance;
        best = c;
      } else if (distance < second_distance) {
        second_distance = distance;
      }
    }
    if (best < 0 || best_distance > kMaxDistanceLow) continue;
    if (static_cast<double>(best_distance) >= 0.7 * static_cast<double>(second_distance)) continue;
    current.points[static_cast<std::size_t>(best)] = point;
    ++matches;
    histogram.add(kf_features.angle_rad[i], features.angle_rad[static_cast<std::size_t>(best)], best);
  }
  return matches - histogram.reject_inconsistent(current.points);
}

bool project_in_frustum(MapPoint& point, const Frame& frame, const Eigen::Vector3d& center,
                        const SearchGeometry& geometry, ProjectedPoint& out) {
  Projection p;
  if (!project(point.position, frame.T_cw, geometry.camera, p)) return false;
  const Eigen::Vector3d ray = point.position - center;
  const double distance = ray.norm();
  if (distance < 0.8 * point.min_distance || distance > 1.2 * point.max_distance) return false;
  const double view_cos = ray.dot(point.normal) / distance;
  if (!(view_cos >= 0.5)) return false;
  out.point = &point;
  out.u = p.u;
  out.v = p.v;
  out.u_right = p.u - geometry.camera.bf() / p.in_camera.z();
  out.level = point.predict_level(distance, geometry.pyramid);
  out.view_cos = view_cos;
  return true;
}

void build_local_queries(const std::vector<ProjectedPoint>& points, double th, const SearchGeometry& geometry,
                         std::vector<ProjectionQuery>& queries, std::vector<Descriptor>& descriptors) {
  queries.resize(points.size());
  descriptors.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ProjectedPoint& p = points[i];
    // A point seen almost head-on moves less in the image between frames: smaller window.
    const double radius =
        (p.view_cos > 0.998 ? 2.5 : 4.0) * th * geometry.pyramid.scale[static_cast<std::size_t>(p.level)];
    ProjectionQuery& q = queries[i];
    q.u_q8 = static_cast<std::int32_t>(std::lround(p.u * 256.0));
    q.v_q8 = static_cast<std::int32_t>(std::lround(p.v * 256.0));
    q.radius_q8 = static_cast<std::int32_t>(std::lround(radius * 256.0));
    q.min_level = static_cast<std::uint8_t>(std::max(0, p.level - 1));
    q.max_level = static_cast<std::uint8_t>(p.level);
    descriptors[i] = p.point->descriptor;
  }
}

int accept_local_matches(Frame& frame, const std::vector<ProjectedPoint>& points,
                         const std::vector<ProjectionQuery>& queries,
                         const std::vector<ProjectionResult>& results) {
  const FrameFeatures& features = *frame.features;
  int matches = 0;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const ProjectionResult& r = results[i];
    if (r.best_index < 0 || r.best_distance > kMaxDistanceHigh) continue;
    // ORB-SLAM2 applies the ratio only when the runner-up is on the best's level; the kernel does
    // not report the runner-up's level, so the ratio applies whenever there is one (stricter).
    if (r.second_distance < 256 &&
        static_cast<double>(r.best_distance) > 0.8 * static_cast<double>(r.second_distance)) {
      continue;
    }
    const auto best = static_cast<std::size_t>(r.best_index);
    if (points[i].point->bad || already_matched(frame, r.best_index)) continue;
    if (features.has_depth(best)) {
      const double radius = queries[i].radius_q8 / 256.0;
      if (std::abs(points[i].u_right - features.u_right[best]) > radius) continue;
    }
    frame.points[best] = points[i].point;
    ++matches;
  }
  return matches;
}

FramePoseProblem frame_pose_problem(Frame& frame, const SearchGeometry& geometry,
                                    double stereo_depth_limit_m) {
  const FrameFeatures& features = *frame.features;
  FramePoseProblem problem;
  for (std::size_t i = 0; i < features.size(); ++i) {
    frame.outlier[i] = false;
    const MapPoint* point = frame.points[i];
    if (point == nullptr) continue;
    optim::PoseObservation o;
    o.point_world = point->position;
    o.u_left = features.uv[i].x();
    o.v = features.uv[i].y();
    const bool stereo = features.has_depth(i) && features.u_right[i] >= 0.0f &&
                        static_cast<double>(features.depth_m[i]) <= stereo_depth_limit_m;
    o.u_right = stereo ? features.u_right[i] : -1.0;
    o.sigma2 = optim::level_sigma2(features.level[i], geometry.pyramid.scale_factor);
    problem.observations.push_back(o);
    problem.feature_of.push_back(i);
  }
  return problem;
}

int apply_frame_pose(Frame& frame, const FramePoseProblem& problem,
                     const optim::PoseOptimizationResult& result) {
  if (!result.optimized) return 0;
  frame.T_cw = result.T_cw;
  for (std::size_t k = 0; k < problem.feature_of.size(); ++k) {
    frame.outlier[problem.feature_of[k]] = !result.inlier[k];
  }
  return result.num_inliers;
}

int optimize_frame_pose(Frame& frame, const SearchGeometry& geometry, double stereo_depth_limit_m) {
  const FramePoseProblem problem = frame_pose_problem(frame, geometry, stereo_depth_limit_m);
  return apply_frame_pose(frame, problem,
                          optim::optimize_pose(geometry.camera, frame.T_cw, problem.observations));
}

int discard_outliers(Frame& frame) {
  int kept = 0;
  for (std::size_t i = 0; i < frame.points.size(); ++i) {
    if (frame.points[i] == nullptr) continue;
    if (frame.outlier[i]) {
      frame.points[i] = nullptr;
      frame.outlier[i] = false;
    } else if (!frame.points[i]->observations.empty()) {
      ++kept;
    }
  }
  return kept;
}

}  // namespace porta::slam::tracking
