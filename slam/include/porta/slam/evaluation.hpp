// Trajectory evaluation (DESIGN.md §6): an estimated trajectory against ground truth.
//
//  1. association: estimate poses are paired with ground-truth poses, by time (nearest GT time within
//     a tolerance, one-to-one) or, when a trajectory has no times (KITTI poses), by index;
//  2. alignment of the estimate onto the ground truth: SE(3) (default), Sim(3) or none, the closed
//     form of Umeyama (1991) on the paired positions;
//  3. metrics: ATE (absolute translational error after alignment), RPE (relative pose error over a
//     frame or distance delta, no alignment needed) and the KITTI odometry relative errors
//     (segments of 100..800 m).
// Poses are T_world_frame (pose.hpp). Report writing and plots are in eval_report.hpp.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "porta/slam/pose.hpp"

namespace porta::slam {

/// An evaluation that cannot be done (no association, too few pairs, counts that differ).
/// what() says what was wrong and what to do.
class EvaluationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// ---- Association ---------------------------------------------------------------------------------

struct AssociationOptions {
  /// A pair's times may differ by at most this (seconds, after the offset). Must be >= 0.
  double max_time_diff_s = 0.02;
  /// Added to every estimate time before matching (estimate clock -> ground-truth clock).
  double time_offset_s = 0.0;
};

/// Pairs (gt_index[k], est_index[k]), ordered by estimate index.
struct Association {
  bool by_index = false;  ///< true: paired by position in the files (a trajectory had no times)
  std::vector<std::size_t> gt_index;
  std::vector<std::size_t> est_index;
  std::size_t gt_count = 0;          ///< poses in the ground truth
  std::size_t est_count = 0;         ///< poses in the estimate
  double max_abs_time_diff_s = 0.0;  ///< over the pairs (0 when by index)

  std::size_t matched() const { return est_index.size(); }
  std::size_t unmatched_estimates() const { return est_count - matched(); }
  std::size_t unmatched_ground_truth() const { return gt_count - matched(); }
};

/// The fewest pairs an evaluation accepts (an alignment needs three points).
inline constexpr std::size_t kMinimumPairs = 3;

/// Pairs the estimate with the ground truth. When both have times: each estimate pose (time + offset)
/// goes to the nearest ground-truth time within max_time_diff_s, one-to-one (the closest pairs are
/// taken first; a GT pose is used at most once). When either has no times: by index, and the counts
/// must be equal. Throws EvaluationError when the counts differ (by index) or fewer than
/// kMinimumPairs pairs are found (the message gives the two time ranges).
Association associate(const Trajectory& ground_truth, const Trajectory& estimate,
                      const AssociationOptions& options = {});

// ---- Alignment -----------------------------------------------------------------------------------

enum class AlignmentMethod { se3, sim3, none };
/// "se3", "sim3", "none"; nullopt otherwise.
std::optional<AlignmentMethod> parse_alignment_method(std::string_view name);
const char* to_string(AlignmentMethod method);

/// p_gt ~= scale * rotation * p_est + translation.
struct Alignment {
  AlignmentMethod method = AlignmentMethod::none;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;

  Eigen::Vector3d apply(const Eigen::Vector3d& p) const { return scale * (rotation * p) + translation; }
  /// The pose moved into the ground-truth frame (its translation scaled, its rotation rotated).
  SE3 apply(const SE3& pose) const;
};

/// The least-squares similarity (Sim(3)), rigid motion (SE(3), scale 1) or identity (none) that maps
/// `estimate` points onto `ground_truth` points (same count, >= 3 unless none). The rotation is a
/// proper rotation (det +1). Throws EvaluationError when the estimate points all coincide (Sim(3)).
Alignment align_points(const std::vector<Eigen::Vector3d>& ground_truth,
                       const std::vector<Eigen::Vector3d>& estimate, AlignmentMethod method);

// ---- Metrics -------------------------------------------------------------------------------------

/// Summary of a list of non-negative errors. All zero when count is 0.
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0, mean = 0.0, median = 0.0, std = 0.0, min = 0.0, max = 0.0;
};
ErrorStats error_stats(const std::vector<double>& errors);

/// Absolute trajectory error of the paired poses after alignment.
struct AteResult {
  std::vector<double> translation_errors_m;  ///< one per pair: |p_gt - align(p_est)|
  std::vector<double> rotation_errors_deg;   ///< one per pair: angle of R_gt^T * R_align * R_est
  ErrorStats translation_m;
  ErrorStats rotation_deg;
};

/// RPE pairs are i < j along the associated sequence, j = i + frames, or (distance mode) the first j
/// whose ground-truth path length from i reaches distance_m.
struct RpeOptions {
  std::size_t delta_frames = 1;   ///< used when delta_distance_m is 0; >= 1
  double delta_distance_m = 0.0;  ///< > 0 selects the distance mode
};

struct RpeResult {
  std::string delta;               ///< "1 frame", "10 frames", "5 m"
  std::vector<std::size_t> first;  ///< pair index (into the association) of each RPE pair's start
  std::vector<std::size_t> second;
  std::vector<double> translation_errors_m;
  std::vector<double> rotation_errors_deg;
  ErrorStats translation_m;
  ErrorStats rotation_deg;
};

/// KITTI odometry relative errors over one segment length.
struct KittiLengthStats {
  double length_m = 0.0;
  std::size_t segments = 0;
  double translation_percent = 0.0;    ///< mean of |t_err| / length, in %
  double rotation_deg_per_100m = 0.0;  ///< mean of angle / length, in deg per 100 m
};

struct KittiResult {
  std::vector<KittiLengthStats> per_length;  ///< lengths with at least one segment
  std::size_t segments = 0;                  ///< over all lengths
  double translation_percent = 0.0;          ///< mean over all segments
  double rotation_deg_per_100m = 0.0;
  double rotation_deg_per_m = 0.0;
  std::string note;  ///< why there are no segments, when there are none
};

/// Segment lengths of the KITTI odometry benchmark: 100, 200, ..., 800 m.
std::vector<double> kitti_segment_lengths_m();
/// Start frames are taken every `start_step` pairs.
inline constexpr std::size_t kKittiStartStep = 10;

/// The relative pose error of one pair: inv(inv(gt_i) * gt_j) * (inv(est_i) * est_j), with the
/// estimate's relative translation multiplied by `scale` (the Sim(3) scale; 1 otherwise).
SE3 relative_pose_error(const SE3& gt_i, const SE3& gt_j, const SE3& est_i, const SE3& est_j,
                        double scale = 1.0);

/// Ground-truth path length from the first pose to each pose (metres; [0] = 0).
std::vector<double> cumulative_distances_m(const std::vector<SE3>& poses);

/// ATE of paired poses (gt[k], est[k]) under `alignment`.
AteResult compute_ate(const std::vector<SE3>& gt, const std::vector<SE3>& est, const Alignment& alignment);
/// RPE of paired poses; `scale` multiplies the estimate's relative translations (Sim(3) evaluation).
RpeResult compute_rpe(const std::vector<SE3>& gt, const std::vector<SE3>& est, const RpeOptions& options,
                      double scale = 1.0);
/// KITTI relative errors of paired poses: for every start s = 0, 10, 20, ... and every length L, the
/// first j with path(s, j) >= L; error = relative_pose_error(gt_s, gt_j, est_s, est_j);
/// t_err = |translation| / L, r_err = angle / L, averaged. Empty (with a note) when the path is
/// shorter than 100 m.
KittiResult compute_kitti(const std::vector<SE3>& gt, const std::vector<SE3>& est, double scale = 1.0);

// ---- The whole evaluation ------------------------------------------------------------------------

enum class KittiMetric { automatic, on, off };

struct EvaluationOptions {
  AssociationOptions association;
  AlignmentMethod alignment = AlignmentMethod::se3;
  RpeOptions rpe;
  /// automatic: computed when the association is by index (KITTI-style inputs).
  KittiMetric kitti = KittiMetric::automatic;
};

struct EvaluationResult {
  Association association;
  Alignment alignment;
  AteResult ate;
  RpeResult rpe;
  std::optional<KittiResult> kitti;    ///< nullopt when not requested
  double gt_path_length_m = 0.0;       ///< whole ground truth
  double matched_path_length_m = 0.0;  ///< ground truth over the paired poses
  double matched_duration_s = 0.0;     ///< ground-truth time span of the pairs (0 without times)

  // Per pair, for plots: time since the first pair (s; the pair index without times) and GT path
  // length from the first pair (m).
  std::vector<double> pair_time_s;
  std::vector<double> pair_distance_m;
  bool pair_has_times = true;
  // Positions for plots: the whole ground truth, and the whole estimate after alignment.
  std::vector<Eigen::Vector3d> gt_positions;
  std::vector<Eigen::Vector3d> aligned_estimate_positions;
};

/// Associates, aligns and computes every metric. Throws EvaluationError (see associate()).
EvaluationResult evaluate(const Trajectory& ground_truth, const Trajectory& estimate,
                          const EvaluationOptions& options = {});

}  // namespace porta::slam
