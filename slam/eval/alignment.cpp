// Aligning an estimate onto the ground truth: the closed-form least-squares similarity of
// Umeyama, "Least-squares estimation of transformation parameters between two point patterns"
// (IEEE PAMI 1991), with its reflection correction.
#include <Eigen/SVD>
#include <string>

#include "porta/slam/evaluation.hpp"

namespace porta::slam {

std::optional<AlignmentMethod> parse_alignment_method(std::string_view name) {
  if (name == "se3") return AlignmentMethod::se3;
  if (name == "sim3") return AlignmentMethod::sim3;
  if (name == "none") return AlignmentMethod::none;
  return std::nullopt;
}

const char* to_string(AlignmentMethod method) {
  switch (method) {
    case AlignmentMethod::se3:
      return "se3";
    case AlignmentMethod::sim3:
      return "sim3";
    case AlignmentMethod::none:
      return "none";
  }
  return "?";
}

SE3 Alignment::apply(const SE3& pose) const {
  SE3 out = SE3::Identity();
  out.linear() = rotation * pose.linear();
  out.translation() = apply(Eigen::Vector3d(pose.translation()));
  return out;
}

Alignment align_points(const std::vector<Eigen::Vector3d>& ground_truth,
                       const std::vector<Eigen::Vector3d>& estimate, AlignmentMethod method) {
  Alignment a;
  a.method = method;
  if (method == AlignmentMethod::none) return a;
  if (ground_truth.size() != estimate.size())
    throw EvaluationError("alignment: " + std::to_string(ground_truth.size()) + " ground-truth points but " +
                          std::to_string(estimate.size()) + " estimate points");
  if (estimate.size() < kMinimumPairs)
    throw EvaluationError("alignment needs at least 3 point pairs, got " + std::to_string(estimate.size()));

  const double n = static_cast<double>(estimate.size());
  Eigen::Vector3d mean_gt = Eigen::Vector3d::Zero(), mean_est = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < estimate.size(); ++k) {
    mean_gt += ground_truth[k];
    mean_est += estimate[k];
  }
  mean_gt /= n;
  mean_est /= n;

  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (1/n) sum (gt - mean)(est - mean)^T
  double est_variance = 0.0;                             // (1/n) sum |est - mean|^2
  for (std::size_t k = 0; k < estimate.size(); ++k) {
    const Eigen::Vector3d g = ground_truth[k] - mean_gt;
    const Eigen::Vector3d e = estimate[k] - mean_est;
    covariance += g * e.transpose();
    est_variance += e.squaredNorm();
  }
  covariance /= n;
  est_variance /= n;

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d sign = Eigen::Vector3d::Ones();
  // A reflection fits best when the points are noisy or degenerate; the nearest rotation flips the
  // axis of the smallest singular value.
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) sign(2) = -1.0;
  a.rotation = svd.matrixU() * sign.asDiagonal() * svd.matrixV().transpose();

  if (method == AlignmentMethod::sim3) {
    if (!(est_variance > 0.0))
      throw EvaluationError(
          "Sim(3) alignment: the estimate's positions all coincide, so no scale can be found");
    a.scale = svd.singularValues().dot(sign) / est_variance;
  }
  a.translation = mean_gt - a.scale * (a.rotation * mean_est);
  return a;
}

}  // namespace porta::slam
