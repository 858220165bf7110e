// The whole evaluation: associate, align, measure (evaluation.hpp).
#include "porta/slam/evaluation.hpp"

#include <cmath>

namespace porta::slam {

EvaluationResult evaluate(const Trajectory& ground_truth, const Trajectory& estimate,
                          const EvaluationOptions& options) {
  EvaluationResult r;
  r.association = associate(ground_truth, estimate, options.association);
  const Association& a = r.association;

  std::vector<SE3> gt, est;
  std::vector<Eigen::Vector3d> gt_points, est_points;
  gt.reserve(a.matched());
  est.reserve(a.matched());
  for (std::size_t k = 0; k < a.matched(); ++k) {
    gt.push_back(ground_truth.poses[a.gt_index[k]].pose);
    est.push_back(estimate.poses[a.est_index[k]].pose);
    gt_points.push_back(gt.back().translation());
    est_points.push_back(est.back().translation());
  }

  r.alignment = align_points(gt_points, est_points, options.alignment);
  r.ate = compute_ate(gt, est, r.alignment);
  r.rpe = compute_rpe(gt, est, options.rpe, r.alignment.scale);
  // A result that is not a number must never be printed as one (and exit 0).
  const double headline[] = {r.ate.translation_m.rmse, r.ate.translation_m.max, r.ate.rotation_deg.rmse,
                             r.rpe.translation_m.rmse, r.rpe.translation_m.max, r.rpe.rotation_deg.rmse,
                             r.alignment.scale};
  for (double v : headline) {
    if (!std::isfinite(v)) {
      throw EvaluationError("the errors are not finite numbers (the positions are too large or degenerate to "
                            "align); check the trajectories' units and values");
    }
  }
  const bool kitti =
      options.kitti == KittiMetric::on || (options.kitti == KittiMetric::automatic && a.by_index);
  if (kitti) r.kitti = compute_kitti(gt, est, r.alignment.scale);

  r.gt_path_length_m = ground_truth.path_length_m();
  r.pair_distance_m = cumulative_distances_m(gt);
  r.matched_path_length_m = r.pair_distance_m.back();
  r.pair_has_times = ground_truth.has_times;
  const double t0 = ground_truth.poses[a.gt_index.front()].time_s;
  for (std::size_t k = 0; k < a.matched(); ++k)
    r.pair_time_s.push_back(r.pair_has_times ? ground_truth.poses[a.gt_index[k]].time_s - t0
                                             : static_cast<double>(k));
  if (r.pair_has_times) r.matched_duration_s = r.pair_time_s.back();

  r.gt_positions.reserve(ground_truth.size());
  for (const StampedPose& p : ground_truth.poses) r.gt_positions.push_back(p.pose.translation());
  r.aligned_estimate_positions.reserve(estimate.size());
  for (const StampedPose& p : estimate.poses)
    r.aligned_estimate_positions.push_back(r.alignment.apply(Eigen::Vector3d(p.pose.translation())));
  return r;
}

}  // namespace porta::slam
