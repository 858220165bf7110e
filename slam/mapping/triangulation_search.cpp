// Local mapping step 3: new map points by triangulation (after ORB-SLAM2's CreateNewMapPoints).
//
// There is no bag-of-words vocabulary, so the candidate matches between two keyframes come from a
// search of the unmatched features constrained by the epipolar geometry: a feature of the neighbour
// is a candidate when it lies within the 95% (1 DoF, 3.84 sigma^2) band around the epipolar line of
// the keyframe's feature. An index of the neighbour's features around the epipole
// (epipolar_pencil_index.hpp) finds those without scanning them all. The best candidate must be
// within TH_LOW and clearly better than the second (ratio 0.6); a neighbour feature keeps only its
// best partner; the rotation-consistency histogram removes matches whose orientation change
// disagrees with most.
//
// Locking: per neighbour, the poses and the unmatched feature lists are copied under Map::mutex,
// the search and triangulation run without it (features are immutable), and the points are
// created under it after checking that both features are still unmatched; the same acquisition
// copies the next neighbour's poses and lists.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <optional>
#include <vector>

#include "cpu/thread_pool.hpp"
#include "epipolar_pencil_index.hpp"
#include "mapping_steps.hpp"
#include "porta/slam/feature_matching.hpp"
#include "porta/slam/optim/chi2.hpp"
#include "porta/slam/optim/triangulation.hpp"

namespace porta::slam::mapping {
namespace {

constexpr double kEpipolarChi2 = 3.84;  // chi-square, 1 DoF, 95%

using Match = FeatureMatch;

struct NewPoint {
  int feature1 = -1;
  int feature2 = -1;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

bool feature_is_free(const KeyFrame& keyframe, std::size_t feature) {
  const MapPoint* point = keyframe.points[feature];
  return point == nullptr || point->bad;
}

std::vector<int> free_features(const KeyFrame& keyframe) {
  std::vector<int> out;
  for (std::size_t i = 0; i < keyframe.points.size(); ++i) {
    if (feature_is_free(keyframe, i)) out.push_back(static_cast<int>(i));
  }
  return out;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// F12 with x1^T F12 x2 = 0 for pixels x1 of keyframe 1 and x2 of keyframe 2 seeing one point.
Eigen::Matrix3d fundamental_matrix(const SE3& T_1w, const SE3& T_2w, const StereoCamera& camera) {
  const SE3 T_12 = T_1w * T_2w.inverse();
  Eigen::Matrix3d K_inv;
  K_inv << 1.0 / camera.fx, 0.0, -camera.cx / camera.fx, 0.0, 1.0 / camera.fy, -camera.cy / camera.fy, 0.0,
      0.0, 1.0;
  return K_inv.transpose() * skew(T_12.translation()) * T_12.linear() * K_inv;
}

/// The free features of keyframe 2 laid out for the epipolar scan, in the index's order (by ring
/// and direction around the epipole): everything the inner loop tests, computed once per keyframe
/// pair instead of once per feature of keyframe 1.
struct EpipolarCandidates {
  std::vector<double> u, v;
  std::vector<double> band;                     ///< chi2 (1 DoF, 95%) x sigma^2 of the feature's level
  std::vector<std::uint8_t> near_epipole_mono;  ///< no stereo depth and within 10 px x scale of the epipole
  std::vector<int> feature;
  std::vector<Descriptor> descriptor;  ///< the features' descriptors, in the same order (contiguous)
  EpipolarPencilIndex index;

  EpipolarCandidates(const FrameFeatures& f2, const std::vector<int>& free2, const Eigen::Vector2d& epipole2,
                     const ScalePyramid& pyramid)
      : index(make_index(f2, free2, epipole2, pyramid)) {
    const std::size_t n = free2.size();
    u.resize(n);
    v.resize(n);
    band.resize(n);
    near_epipole_mono.resize(n);
    feature.resize(n);
    descriptor.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      const auto s2 = static_cast<std::size_t>(free2[static_cast<std::size_t>(index.order()[k])]);
      feature[k] = static_cast<int>(s2);
      descriptor[k] = f2.descriptors[s2];
      u[k] = f2.uv[s2].x();
      v[k] = f2.uv[s2].y();
      band[k] = kEpipolarChi2 * pyramid.sigma2[f2.level[s2]];
      const double dx = epipole2.x() - u[k], dy = epipole2.y() - v[k];
      near_epipole_mono[k] = !f2.has_depth(s2) && dx * dx + dy * dy < 100.0 * pyramid.scale[f2.level[s2]];
    }
  }

  static EpipolarPencilIndex make_index(const FrameFeatures& f2, const std::vector<int>& free2,
                                        const Eigen::Vector2d& epipole2, const ScalePyramid& pyramid) {
    std::vector<double> u, v;
    double max_band = 0.0;
    for (const int i2 : free2) {
      const auto s2 = static_cast<std::size_t>(i2);
      u.push_back(f2.uv[s2].x());
      v.push_back(f2.uv[s2].y());
      max_band = std::max(max_band, kEpipolarChi2 * pyramid.sigma2[f2.level[s2]]);
    }
    return EpipolarPencilIndex(u, v, epipole2, std::sqrt(max_band));
  }
};

/// The best and second-best Hamming distance of one feature of keyframe 1 among the candidates
/// in its epipolar band, and the best one's feature (-1: none).
struct BestCandidate {
  int i2 = -1;
  int best = 256;
  int second = 256;
};

/// One keyframe pair's search set-up: the poses it was made from, the free features of keyframe 2
/// in the band index, and the fundamental matrix.
struct PairSearch {
  SE3 T_1w, T_2w;
  std::vector<int> free2;
  Eigen::Matrix3d F12;
  EpipolarCandidates candidates;

  PairSearch(const SE3& T_1w_in, const SE3& T_2w_in, std::vector<int> free2_in, const FrameFeatures& f2,
             const StereoCamera& camera, const ScalePyramid& pyramid)
      : T_1w(T_1w_in),
        T_2w(T_2w_in),
        free2(std::move(free2_in)),
        F12(fundamental_matrix(T_1w, T_2w, camera)),
        candidates(f2, free2, epipole_in_2(T_1w, T_2w, camera), pyramid) {}

  /// The image in keyframe 2 of keyframe 1's centre (far out when it lies in keyframe 2's focal plane).
  static Eigen::Vector2d epipole_in_2(const SE3& T_1w, const SE3& T_2w, const StereoCamera& camera) {
    const Eigen::Vector3d c1_in_2 = T_2w * T_1w.inverse().translation();
    if (std::abs(c1_in_2.z()) <= 1e-12) return {-1e9, -1e9};
    return {camera.fx * c1_in_2.x() / c1_in_2.z() + camera.cx,
            camera.fy * c1_in_2.y() / c1_in_2.z() + camera.cy};
  }

  /// The search for feature i1 of keyframe 1; it depends on nothing else, so features may be
  /// searched in any order, on any thread.
  BestCandidate search(const FrameFeatures& f1, int i1) const {
    const auto s1 = static_cast<std::size_t>(i1);
    BestCandidate result;
    const Descriptor query = f1.descriptors[s1];
    const Eigen::Vector3d line = F12.transpose() * Eigen::Vector3d(f1.uv[s1].x(), f1.uv[s1].y(), 1.0);
    const double line_norm2 = line.x() * line.x() + line.y() * line.y();
    if (!(line_norm2 > 0.0)) return result;
    // Without stereo depth on either side, a ray nearly along the baseline has no usable depth.
    const bool skip_near_epipole = !f1.has_depth(s1);
    // Two passes per block of the range: which candidates lie in their band, without a branch (a
    // quarter do, in no predictable pattern: the branch of a one-pass loop mispredicted most of
    // its time away), then the descriptor distances of those, in the same ascending order.
    constexpr int kBlock = 128;
    std::array<int, kBlock> in_band;
    const double a = line.x(), b = line.y(), c = line.z();
    candidates.index.visit_band(line, [&](int first, int last) {
      for (int begin = first; begin < last; begin += kBlock) {
        const int end = std::min(last, begin + kBlock);
        int count = 0;
        for (int k = begin; k < end; ++k) {
          const auto s = static_cast<std::size_t>(k);
          // Squared distance to the epipolar line within the band (num^2 / |line|^2 < band).
          const double num = a * candidates.u[s] + b * candidates.v[s] + c;
          const int outside_band = num * num >= candidates.band[s] * line_norm2 ? 1 : 0;
          const int skipped = skip_near_epipole ? candidates.near_epipole_mono[s] : 0;  // 0 or 1
          in_band[static_cast<std::size_t>(count)] = k;
          count += 1 - (outside_band | skipped);
        }
        for (int j = 0; j < count; ++j) {
          const auto k = static_cast<std::size_t>(in_band[static_cast<std::size_t>(j)]);
          const int i2 = candidates.feature[k];
          const int distance = descriptor_distance(query, candidates.descriptor[k]);
          if (distance < result.best || (distance == result.best && i2 < result.i2)) {
            result.second = result.best;
            result.best = distance;
            result.i2 = i2;
          } else if (distance < result.second) {
            result.second = distance;
          }
        }
      }
    });
    return result;
  }
};

/// The matches of the epipolar search: each feature of `free1` (ascending) takes its best
/// candidate when within TH_LOW and below ratio x the second; a feature of keyframe 2 keeps its
/// closest partner; then the rotation histogram. `best_of(i1)` gives the search's result.
template <class BestOf>
std::vector<Match> resolve_matches(const FrameFeatures& f1, const std::vector<int>& free1,
                                   const FrameFeatures& f2, BestOf&& best_of) {
  // Best partner of each feature of keyframe 2 (index into `matches`, -1 none): uniqueness.
  std::vector<int> taken_by(f2.size(), -1);
  std::vector<Match> matches;
  for (const int i1 : free1) {
    const BestCandidate c = best_of(i1);
    if (c.i2 < 0 || c.best > kHammingLow || !(c.best < kMatchRatio * c.second)) continue;
    int& owner = taken_by[static_cast<std::size_t>(c.i2)];
    if (owner >= 0) {
      Match& previous = matches[static_cast<std::size_t>(owner)];
      if (previous.distance <= c.best) continue;  // ties keep the smaller feature index
      previous = {i1, c.i2, c.best};
    } else {
      owner = static_cast<int>(matches.size());
      matches.push_back({i1, c.i2, c.best});
    }
  }
  keep_consistent_rotations(matches, f1, f2);
  return matches;
}

/// One view of a match: pose, keypoint and whether the keypoint has a stereo match.
struct View {
  SE3 T_cw;
  Eigen::Vector3d center;
  double u = 0.0, v = 0.0, u_right = -1.0, depth = -1.0;
  int level = 0;
  bool stereo() const { return depth > 0.0; }
};

View make_view(const SE3& T_cw, const Eigen::Vector3d& center, const FrameFeatures& f, int feature) {
  const auto s = static_cast<std::size_t>(feature);
  View view{T_cw, center};
  view.u = f.uv[s].x();
  view.v = f.uv[s].y();
  view.level = f.level[s];
  if (f.has_depth(s)) {
    view.u_right = f.u_right[s];
    view.depth = f.depth_m[s];
  }
  return view;
}

bool reprojects(const StereoCamera& camera, const View& view, const Eigen::Vector3d& point, double sigma2) {
  return view.stereo() ? optim::stereo_reprojection_within(camera, view.T_cw, point, view.u, view.v,
                                                           view.u_right, sigma2, optim::kChi2Stereo95)
                       : optim::reprojection_within(camera, view.T_cw, point, view.u, view.v, sigma2,
                                                    optim::kChi2Mono95);
}

/// ORB-SLAM2's choice between linear triangulation (enough ray parallax) and the stereo depth of
/// whichever view has the larger stereo parallax, then its checks: positive depth, reprojection
/// chi2 in both views and scale consistency.
std::optional<Eigen::Vector3d> triangulate_match(const StereoCamera& camera, const ScalePyramid& pyramid,
                                                 const View& view1, const View& view2) {
  const Eigen::Vector2d x1 = optim::normalize_pixel(camera, view1.u, view1.v);
  const Eigen::Vector2d x2 = optim::normalize_pixel(camera, view2.u, view2.v);
  const double cos_rays = optim::ray_parallax_cosine(view1.T_cw, x1, view2.T_cw, x2);
  // Parallax of the stereo pair at the measured depth: the angle the baseline subtends.
  const double half_baseline = 0.5 * camera.baseline_m;
  const double cos_stereo1 = view1.stereo() ? std::cos(2.0 * std::atan2(half_baseline, view1.depth)) : 2.0;
  const double cos_stereo2 = view2.stereo() ? std::cos(2.0 * std::atan2(half_baseline, view2.depth)) : 2.0;
  const double cos_stereo = std::min({cos_rays + 1.0, cos_stereo1, cos_stereo2});

  std::optional<Eigen::Vector3d> point;
  if (cos_rays < cos_stereo && cos_rays > 0.0 &&
      (view1.stereo() || view2.stereo() || cos_rays < optim::kMaxParallaxCosine)) {
    point = optim::triangulate_linear(view1.T_cw, x1, view2.T_cw, x2);
  } else if (view1.stereo() && cos_stereo1 < cos_stereo2) {
    point = optim::stereo_backproject_world(camera, view1.T_cw, view1.u, view1.v, view1.u_right);
  } else if (view2.stereo() && cos_stereo2 < cos_stereo1) {
    point = optim::stereo_backproject_world(camera, view2.T_cw, view2.u, view2.v, view2.u_right);
  }
  if (!point) return std::nullopt;
  if (!optim::has_positive_depth(view1.T_cw, *point) || !optim::has_positive_depth(view2.T_cw, *point)) {
    return std::nullopt;
  }
  if (!reprojects(camera, view1, *point, pyramid.sigma2[static_cast<std::size_t>(view1.level)]) ||
      !reprojects(camera, view2, *point, pyramid.sigma2[static_cast<std::size_t>(view2.level)])) {
    return std::nullopt;
  }
  const double distance1 = (*point - view1.center).norm();
  const double distance2 = (*point - view2.center).norm();
  if (!(distance1 > 0.0) || !(distance2 > 0.0)) return std::nullopt;
  const double ratio_distance = distance2 / distance1;
  const double ratio_octave = pyramid.scale[static_cast<std::size_t>(view1.level)] /
                              pyramid.scale[static_cast<std::size_t>(view2.level)];
  const double ratio_factor = 1.5 * pyramid.scale_factor;
  if (ratio_distance * ratio_factor < ratio_octave || ratio_distance > ratio_octave * ratio_factor) {
    return std::nullopt;
  }
  return point;
}

/// With a pool: every neighbour's search set up from one snapshot of the map, and every free
/// feature of the keyframe searched in every neighbour at once, in parallel. Each search depends on
/// its pair's poses and free features only, so the sequential pass below takes these results
/// wherever its own snapshot of the pair is the same, and the matches are those it would find.
struct SearchedAhead {
  std::vector<std::optional<PairSearch>> pairs;  // per neighbour; none: short baseline or bad
  std::vector<std::vector<BestCandidate>> best;  // per neighbour, per feature of keyframe 1
  std::vector<std::uint8_t> searched;            // per feature of keyframe 1: in `best`
};

SearchedAhead search_ahead(Map& map, KeyFrame* keyframe, const std::vector<KeyFrame*>& neighbours,
                           const StereoCamera& camera, const ScalePyramid& pyramid, cpu::ThreadPool& pool) {
  const std::size_t count = neighbours.size();
  SearchedAhead ahead;
  ahead.pairs.resize(count);
  ahead.best.resize(count);
  SE3 T_1w;
  std::vector<int> free1;
  std::vector<SE3> T_2w(count);
  std::vector<std::vector<int>> free2(count);
  std::vector<std::uint8_t> usable(count, 0);
  {
    std::lock_guard lock(map.mutex);
    if (keyframe->bad) return ahead;
    T_1w = keyframe->T_cw;
    free1 = free_features(*keyframe);
    for (std::size_t n = 0; n < count; ++n) {
      if (neighbours[n]->bad) continue;
      T_2w[n] = neighbours[n]->T_cw;
      free2[n] = free_features(*neighbours[n]);
      usable[n] = 1;
    }
  }
  const FrameFeatures& f1 = *keyframe->features;
  const Eigen::Vector3d center1 = T_1w.inverse().translation();
  pool.parallel_for(0, static_cast<std::int64_t>(count), [&](std::int64_t i) {
    const auto n = static_cast<std::size_t>(i);
    if (usable[n] == 0 || (T_2w[n].inverse().translation() - center1).norm() < camera.baseline_m) return;
    ahead.pairs[n].emplace(T_1w, T_2w[n], std::move(free2[n]), *neighbours[n]->features, camera, pyramid);
    ahead.best[n].resize(f1.size());
  });
  const auto per_pair = static_cast<std::int64_t>(free1.size());
  pool.parallel_for(0, static_cast<std::int64_t>(count) * per_pair, [&](std::int64_t i) {
    const auto n = static_cast<std::size_t>(i / per_pair);
    if (!ahead.pairs[n]) return;
    const int i1 = free1[static_cast<std::size_t>(i % per_pair)];
    ahead.best[n][static_cast<std::size_t>(i1)] = ahead.pairs[n]->search(f1, i1);
  });
  ahead.searched.assign(f1.size(), 0);
  for (const int i1 : free1) ahead.searched[static_cast<std::size_t>(i1)] = 1;
  return ahead;
}

}  // namespace

int triangulate_new_points(Map& map, KeyFrame* keyframe, const SlamSettings& settings,
                           const ScalePyramid& pyramid, std::vector<MapPoint*>& recent,
                           const std::function<bool()>& should_stop, bool first_neighbour_only,
                           cpu::ThreadPool* pool) {
  const StereoCamera& camera = settings.camera;
  std::vector<KeyFrame*> neighbours;
  {
    std::lock_guard lock(map.mutex);
    if (keyframe->bad) return 0;
    neighbours = keyframe->best_covisibles(kNeighbours);
  }
  const FrameFeatures& f1 = *keyframe->features;
  SearchedAhead ahead;
  if (pool != nullptr && pool->size() > 1) {
    // Keyframes already waiting stay waiting (only the mapping thread takes them): should_stop()
    // then ends the pass after the first neighbour, and a search made ahead for the others would
    // be thrown away.
    const std::size_t count = first_neighbour_only ? std::min<std::size_t>(neighbours.size(), 1) : neighbours.size();
    const std::vector<KeyFrame*> searched(neighbours.begin(), neighbours.begin() + static_cast<std::ptrdiff_t>(count));
    ahead = search_ahead(map, keyframe, searched, camera, pyramid, *pool);
  }
  // What the pass reads of one pair under the lock: the poses and the unmatched features.
  struct Snapshot {
    std::uint64_t generation = 0;
    SE3 T_1w, T_2w;
    std::vector<int> free1, free2;
  };
  // Caller holds the lock; false: either keyframe is bad.
  const auto take_snapshot = [&](KeyFrame* other, Snapshot& snapshot) {
    if (keyframe->bad || other->bad) return false;
    snapshot.generation = map.correction_generation;
    snapshot.T_1w = keyframe->T_cw;
    snapshot.T_2w = other->T_cw;
    snapshot.free1 = free_features(*keyframe);
    snapshot.free2 = free_features(*other);
    return true;
  };
  // The next neighbour's snapshot is taken under the lock that creates this one's points: one
  // acquisition per neighbour instead of two (tracking keeps the lock for its whole frame, so each
  // acquisition may wait for one). `should_stop` is asked before that lock, not after it.
  enum class Next { none, taken, bad };
  Next next = Next::none;
  Snapshot snapshot;
  int created = 0;
  for (std::size_t n = 0; n < neighbours.size(); ++n) {
    KeyFrame* other = neighbours[n];
    if (next == Next::bad) {
      next = Next::none;
      continue;
    }
    if (next == Next::none) {
      if (n > 0 && should_stop && should_stop()) break;
      std::lock_guard lock(map.mutex);
      if (!take_snapshot(other, snapshot)) continue;
    }
    next = Next::none;
    const SE3 T_1w = snapshot.T_1w, T_2w = snapshot.T_2w;
    const std::uint64_t generation = snapshot.generation;
    const std::vector<int> free1 = std::move(snapshot.free1);
    std::vector<int> free2 = std::move(snapshot.free2);
    const Eigen::Vector3d center1 = T_1w.inverse().translation();
    const Eigen::Vector3d center2 = T_2w.inverse().translation();
    // Stereo: a baseline shorter than the camera's own gives nothing its stereo depth does not.
    if ((center2 - center1).norm() < camera.baseline_m) continue;

    const FrameFeatures& f2 = *other->features;
    // The search made ahead serves when it was made from this same snapshot of the pair.
    const PairSearch* pair = n < ahead.pairs.size() && ahead.pairs[n] ? &*ahead.pairs[n] : nullptr;
    const bool ahead_serves = pair != nullptr && pair->T_1w.matrix() == T_1w.matrix() &&
                              pair->T_2w.matrix() == T_2w.matrix() && pair->free2 == free2;
    std::optional<PairSearch> here;
    if (!ahead_serves) pair = &here.emplace(T_1w, T_2w, std::move(free2), f2, camera, pyramid);
    const std::vector<Match> matches = resolve_matches(f1, free1, f2, [&](int i1) {
      const auto s1 = static_cast<std::size_t>(i1);
      return ahead_serves && ahead.searched[s1] != 0 ? ahead.best[n][s1] : pair->search(f1, i1);
    });

    std::vector<NewPoint> new_points;
    for (const Match& match : matches) {
      const View view1 = make_view(T_1w, center1, f1, match.feature1);
      const View view2 = make_view(T_2w, center2, f2, match.feature2);
      if (const auto point = triangulate_match(camera, pyramid, view1, view2)) {
        new_points.push_back({match.feature1, match.feature2, *point});
      }
    }

    const bool last = n + 1 == neighbours.size() || (should_stop && should_stop());
    std::lock_guard lock(map.mutex);
    // A loop correction moved the keyframes meanwhile: these points are in the old map's frame.
    if (!keyframe->bad && !other->bad && map.correction_generation == generation) {
      for (const NewPoint& candidate : new_points) {
        const auto s1 = static_cast<std::size_t>(candidate.feature1);
        const auto s2 = static_cast<std::size_t>(candidate.feature2);
        if (!feature_is_free(*keyframe, s1) || !feature_is_free(*other, s2)) continue;
        MapPoint* point = map.add_point(candidate.position, keyframe, keyframe->frame_id);
        Map::add_observation(point, keyframe, candidate.feature1);
        Map::add_observation(point, other, candidate.feature2);
        point->update_descriptor();
        point->update_normal_and_depth(pyramid);
        recent.push_back(point);
        ++created;
      }
    }
    if (last) break;
    next = take_snapshot(neighbours[n + 1], snapshot) ? Next::taken : Next::bad;
  }
  return created;
}

}  // namespace porta::slam::mapping
