// Rigid alignment (Horn / Umeyama) and its RANSAC between two stereo keyframes; see rigid_alignment.hpp.
#include "porta/slam/optim/rigid_alignment.hpp"

#include <Eigen/SVD>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "porta/slam/optim/ransac_random.hpp"

namespace porta::slam::optim {
namespace {

// Singular values of the cross-covariance scale with length^2: a ratio of 1e-9 between the second
// and the first means a spread across the line ~3e-5 of the spread along it (1 mm over 30 m), where
// the rotation about the line is no longer determined by the data.
constexpr double kDegenerateSingularRatio = 1e-9;

bool pixel_error_within(const StereoCamera& camera, const Eigen::Vector3d& p, const Eigen::Vector2d& uv,
                        double bound) {
  if (!(p.z() > 0.0)) return false;  // a point behind the camera projects onto a valid-looking pixel
  const double du = camera.fx * p.x() / p.z() + camera.cx - uv.x();
  const double dv = camera.fy * p.y() / p.z() + camera.cy - uv.y();
  return du * du + dv * dv < bound;
}

// Marks the inliers of T_ab (both reprojections within chi2 * sigma2) and returns their number.
int classify(const StereoCamera& camera, std::span<const RigidCorrespondence> c, const SE3& T_ab, double chi2,
             std::vector<bool>& inlier) {
  const SE3 T_ba = T_ab.inverse();
  int count = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    inlier[i] = pixel_error_within(camera, T_ab * c[i].point_b, c[i].uv_a, chi2 * c[i].sigma2_a) &&
                pixel_error_within(camera, T_ba * c[i].point_a, c[i].uv_b, chi2 * c[i].sigma2_b);
    count += inlier[i] ? 1 : 0;
  }
  return count;
}

void validate(const RigidRansacOptions& o, std::span<const RigidCorrespondence> c) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("ransac_rigid: " + what); };
  if (!(o.probability > 0.0 && o.probability < 1.0))
    fail("options.probability is " + std::to_string(o.probability) + ", must be in (0, 1)");
  if (o.min_inliers < 3) fail("options.min_inliers is " + std::to_string(o.min_inliers) + ", must be >= 3");
  if (o.max_iterations < 1)
    fail("options.max_iterations is " + std::to_string(o.max_iterations) + ", must be >= 1");
  if (!(o.chi2 > 0.0) || !std::isfinite(o.chi2))
    fail("options.chi2 is " + std::to_string(o.chi2) + ", must be > 0 and finite");
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (!(c[i].sigma2_a > 0.0) || !(c[i].sigma2_b > 0.0))
      fail("correspondence " + std::to_string(i) + " has sigma2_a " + std::to_string(c[i].sigma2_a) +
           " and sigma2_b " + std::to_string(c[i].sigma2_b) + ", both must be > 0");
  }
}

}  // namespace

std::optional<SE3> align_rigid(std::span<const Eigen::Vector3d> from, std::span<const Eigen::Vector3d> to) {
  if (from.size() != to.size() || from.size() < 3) return std::nullopt;
  const double inv_n = 1.0 / static_cast<double>(from.size());
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    mean_from += from[i];
    mean_to += to[i];
  }
  mean_from *= inv_n;
  mean_to *= inv_n;
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();  // sum (to - mean_to)(from - mean_from)^T
  for (std::size_t i = 0; i < from.size(); ++i)
    cross += (to[i] - mean_to) * (from[i] - mean_from).transpose();
  if (!cross.allFinite() || !mean_from.allFinite() || !mean_to.allFinite()) return std::nullopt;

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d& s = svd.singularValues();  // descending
  if (!(s(0) > 0.0) || !(s(1) > kDegenerateSingularRatio * s(0))) return std::nullopt;
  // R = U diag(1, 1, d) V^T with d = det(U V^T): the best rotation rather than the best reflection
  // (Umeyama 1991). For coplanar points s(2) = 0 and the sign of that axis is free: d fixes it.
  Eigen::Vector3d d(1.0, 1.0, (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0);
  SE3 T = SE3::Identity();
  T.linear() = svd.matrixU() * d.asDiagonal() * svd.matrixV().transpose();
  T.translation() = mean_to - T.linear() * mean_from;
  if (!T.matrix().allFinite()) return std::nullopt;
  return T;
}

RigidRansacResult ransac_rigid(const StereoCamera& camera, std::span<const RigidCorrespondence> c,
                               const RigidRansacOptions& options) {
  camera.validate();
  validate(options, c);
  RigidRansacResult result;
  result.inlier.assign(c.size(), false);
  if (c.size() < static_cast<std::size_t>(options.min_inliers)) return result;  // min_inliers >= 3

  constexpr int kSampleSize = 3;
  SplitMix64 rng(options.seed);
  std::array<std::size_t, kSampleSize> sample{};
  std::array<Eigen::Vector3d, kSampleSize> sample_b, sample_a;
  std::vector<bool> inlier(c.size(), false);
  int best_inliers = -1;
  SE3 best_T = SE3::Identity();
  int needed_iterations = options.max_iterations;
  while (result.iterations < needed_iterations) {
    ++result.iterations;
    sample_distinct_indices(rng, c.size(), sample);
    for (int k = 0; k < kSampleSize; ++k) {
      sample_b[k] = c[sample[k]].point_b;
      sample_a[k] = c[sample[k]].point_a;
    }
    const std::optional<SE3> T_ab = align_rigid(sample_b, sample_a);
    if (!T_ab) continue;
    const int count = classify(camera, c, *T_ab, options.chi2, inlier);
    if (count > best_inliers) {  // strictly more: ties keep the first found
      best_inliers = count;
      best_T = *T_ab;
      result.inlier = inlier;
      needed_iterations = ransac_required_iterations(
          options.probability, static_cast<double>(count) / static_cast<double>(c.size()), kSampleSize,
          options.max_iterations);
    }
  }
  if (best_inliers <= 0) {  // every sample degenerate, or no hypothesis explains anything
    result.inlier.assign(c.size(), false);
    return result;
  }

  // Refine on all inliers of the winner (the minimal sample's pose carries its three points' noise);
  // align_rigid declines fewer than 3.
  std::vector<Eigen::Vector3d> inlier_b, inlier_a;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (!result.inlier[i]) continue;
    inlier_b.push_back(c[i].point_b);
    inlier_a.push_back(c[i].point_a);
  }
  if (const std::optional<SE3> refined = align_rigid(inlier_b, inlier_a)) {
    const int count = classify(camera, c, *refined, options.chi2, inlier);
    if (count >= best_inliers) {
      best_inliers = count;
      best_T = *refined;
      result.inlier = inlier;
    }
  }
  result.T_ab = best_T;
  result.num_inliers = best_inliers;
  result.found = best_inliers >= options.min_inliers;
  return result;
}

}  // namespace porta::slam::optim
