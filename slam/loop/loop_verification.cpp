// Loop closing step 2: geometric verification of a loop candidate (after ORB-SLAM2's
// LoopClosing::ComputeSim3, with SE(3) for stereo); see loop_steps.hpp. The caller holds Map::mutex,
// except for match_loop_features (descriptors only).
#include <algorithm>
#include <set>

#include "loop_steps.hpp"
#include "porta/slam/feature_matching.hpp"
#include "porta/slam/optim/pose_optimization.hpp"
#include "porta/slam/optim/rigid_alignment.hpp"

namespace porta::slam::loop {
namespace {

constexpr int kHammingLow = 50;             // ORB-SLAM2's TH_LOW
constexpr double kMatchRatio = 0.75;        // ORB-SLAM2's SearchByBoW ratio for loops
constexpr double kGuidedWindowPx = 10.0;    // ORB-SLAM2's SearchByProjection(th = 10)

MapPoint* good_point(const KeyFrame& keyframe, std::size_t feature) {
  MapPoint* p = keyframe.points[feature];
  return p != nullptr && !p->bad ? p : nullptr;
}

}  // namespace

std::vector<int> features_with_points(const KeyFrame& keyframe) {
  std::vector<int> out;
  for (std::size_t i = 0; i < keyframe.points.size(); ++i) {
    if (good_point(keyframe, i) != nullptr) out.push_back(static_cast<int>(i));
  }
  return out;
}

std::vector<FeatureMatch> match_loop_features(const KeyFrame& query, const std::vector<int>& from_query,
                                              const KeyFrame& candidate, const std::vector<int>& from_candidate) {
  return match_by_descriptor(*query.features, from_query, *candidate.features, from_candidate, kHammingLow,
                             kMatchRatio);
}

namespace {

/// The points of `candidate` and all its covisibles (by weight), each once.
std::vector<MapPoint*> loop_group_points(KeyFrame* candidate) {
  std::vector<KeyFrame*> group{candidate};
  for (KeyFrame* k : candidate->covisibles_with_weight(0)) group.push_back(k);
  std::set<std::uint64_t> seen;
  std::vector<MapPoint*> points;
  for (KeyFrame* k : group) {
    for (MapPoint* p : k->points) {
      if (p != nullptr && !p->bad && seen.insert(p->id).second) points.push_back(p);
    }
  }
  return points;
}

/// ORB-SLAM2's SearchByProjection(KeyFrame, Scw, points): each point not matched yet projected
/// with T_qw into `query`, window 10 * scale of the predicted level, levels [predicted - 1,
/// predicted], best distance <= TH_LOW, features not matched yet. Returns the new matches.
int search_by_projection(const KeyFrame& query, const SE3& T_qw, const std::vector<MapPoint*>& points,
                         const StereoCamera& camera, const ScalePyramid& pyramid, std::vector<MapPoint*>& matched) {
  const FrameFeatures& f = *query.features;
  std::set<std::uint64_t> already;
  for (const MapPoint* p : matched) {
    if (p != nullptr) already.insert(p->id);
  }
  const Eigen::Vector3d center = T_qw.inverse().translation();
  int added = 0;
  for (MapPoint* point : points) {
    if (already.count(point->id) != 0) continue;
    const Eigen::Vector3d p_c = T_qw * point->position;
    if (!(p_c.z() > 0.0)) continue;
    const double u = camera.fx * p_c.x() / p_c.z() + camera.cx;
    const double v = camera.fy * p_c.y() / p_c.z() + camera.cy;
    if (u < 0.0 || u >= camera.width || v < 0.0 || v >= camera.height) continue;
    const Eigen::Vector3d ray = point->position - center;
    const double distance = ray.norm();
    if (distance < 0.8 * point->min_distance || distance > 1.2 * point->max_distance) continue;
    if (ray.dot(point->normal) < 0.5 * distance) continue;
    const int level = point->predict_level(distance, pyramid);
    const double radius = kGuidedWindowPx * pyramid.scale[static_cast<std::size_t>(level)];
    int best = 256, best_feature = -1;
    for (const int i : query.grid.in_area(f, static_cast<float>(u), static_cast<float>(v),
                                          static_cast<float>(radius), std::max(0, level - 1), level)) {
      if (matched[static_cast<std::size_t>(i)] != nullptr) continue;
      const int d = hamming_distance(point->descriptor, f.descriptors[static_cast<std::size_t>(i)]);
      if (d < best) {
        best = d;
        best_feature = i;
      }
    }
    if (best_feature < 0 || best > kHammingLow) continue;
    matched[static_cast<std::size_t>(best_feature)] = point;
    ++added;
  }
  return added;
}

}  // namespace

bool verify_loop(KeyFrame* query, KeyFrame* candidate, std::vector<FeatureMatch> matches,
                 const SlamSettings& settings, const ScalePyramid& pyramid, LoopMatch& out) {
  out = LoopMatch{};
  const StereoCamera& camera = settings.camera;
  const FrameFeatures& fq = *query->features;
  const FrameFeatures& fc = *candidate->features;
  // Matched without the lock: a point may have gone bad (culled, fused) since.
  std::erase_if(matches, [&](const FeatureMatch& m) {
    return good_point(*query, static_cast<std::size_t>(m.feature1)) == nullptr ||
           good_point(*candidate, static_cast<std::size_t>(m.feature2)) == nullptr;
  });
  out.matches = static_cast<int>(matches.size());
  if (out.matches < kMinMatches) {
    out.rejected = std::to_string(out.matches) + " descriptor matches (need " + std::to_string(kMinMatches) + ")";
    return false;
  }

  std::vector<optim::RigidCorrespondence> pairs;
  for (const FeatureMatch& m : matches) {
    const auto i = static_cast<std::size_t>(m.feature1), j = static_cast<std::size_t>(m.feature2);
    optim::RigidCorrespondence c;
    c.point_a = query->T_cw * query->points[i]->position;
    c.point_b = candidate->T_cw * candidate->points[j]->position;
    c.uv_a = fq.uv[i].cast<double>();
    c.uv_b = fc.uv[j].cast<double>();
    c.sigma2_a = pyramid.sigma2[fq.level[i]];
    c.sigma2_b = pyramid.sigma2[fc.level[j]];
    pairs.push_back(c);
  }
  optim::RigidRansacOptions ransac;
  ransac.min_inliers = kMinRansacInliers;
  ransac.seed = 0x5eed0000u + query->id;  // reproducible, and different per query
  const optim::RigidRansacResult rigid = optim::ransac_rigid(camera, pairs, ransac);
  out.ransac_inliers = rigid.num_inliers;
  if (!rigid.found) {
    out.rejected = "RANSAC found " + std::to_string(rigid.num_inliers) + " inliers of " +
                   std::to_string(out.matches) + " matches (need " + std::to_string(kMinRansacInliers) + ")";
    return false;
  }

  // The query keyframe as the loop's side of the map sees it.
  const SE3 T_qw = rigid.T_ab * candidate->T_cw;
  out.matched.assign(fq.size(), nullptr);
  for (std::size_t m = 0; m < matches.size(); ++m) {
    if (rigid.inlier[m]) {
      out.matched[static_cast<std::size_t>(matches[m].feature1)] = good_point(*candidate,
                                                                              static_cast<std::size_t>(matches[m].feature2));
    }
  }
  out.loop_points = loop_group_points(candidate);
  search_by_projection(*query, T_qw, out.loop_points, camera, pyramid, out.matched);

  std::vector<optim::PoseObservation> observations;
  std::vector<std::size_t> feature_of;
  for (std::size_t i = 0; i < fq.size(); ++i) {
    const MapPoint* p = out.matched[i];
    if (p == nullptr) continue;
    optim::PoseObservation o;
    o.point_world = p->position;
    o.u_left = fq.uv[i].x();
    o.v = fq.uv[i].y();
    o.u_right = fq.has_depth(i) ? static_cast<double>(fq.u_right[i]) : -1.0;
    o.sigma2 = pyramid.sigma2[fq.level[i]];
    observations.push_back(o);
    feature_of.push_back(i);
  }
  if (static_cast<int>(observations.size()) < kMinLoopInliers) {
    out.rejected = std::to_string(observations.size()) + " matches after the guided search (need " +
                   std::to_string(kMinLoopInliers) + ")";
    return false;
  }
  const optim::PoseOptimizationResult pose = optim::optimize_pose(camera, T_qw, observations);
  for (std::size_t k = 0; k < observations.size(); ++k) {
    if (!pose.inlier[k]) out.matched[feature_of[k]] = nullptr;
  }
  out.inliers = pose.num_inliers;
  out.T_qw = pose.T_cw;
  if (out.inliers < kMinLoopInliers) {
    out.rejected = std::to_string(out.inliers) + " inliers after the guided search and pose optimisation (need " +
                   std::to_string(kMinLoopInliers) + ")";
    return false;
  }
  return true;
}

}  // namespace porta::slam::loop
