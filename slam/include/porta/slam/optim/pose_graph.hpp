// SE(3) pose-graph optimisation: loop closing's optimisation of ORB-SLAM2's essential graph after a
// loop is found (stereo: the scale is observable, so SE(3) rather than ORB-SLAM2's Sim(3)).
//
// Vertices are T_cw (world -> camera) on Se3Manifold (see se3_manifold.hpp). An edge (i, j) measures
// T_ij = T_iw * T_jw^-1 (camera j -> camera i); its residual is
//   r = sqrt(weight) * log(T_ij^-1 * T_iw * T_jw^-1)   in the tangent order [phi; rho] (se3_log),
// zero when the vertices agree with the measurement; the Ceres cost is 1/2 sum |r|^2. Levenberg-
// Marquardt on the sparse normal equations (dense where Ceres has no sparse library). Fixed vertices
// are held constant and returned as bit-identical copies; when no vertex with an edge is fixed, the
// lowest-index vertex with an edge (vertex 0 in a connected graph) is held fixed to remove the gauge
// freedom. Each connected component should hold a fixed vertex: an unanchored one is kept finite by
// the LM damping only. Vertices without edges are returned as copies. With num_threads = 1 the result is
// deterministic (bit-identical for the same input). Residual rotations must stay below pi.
#pragma once

#include <ceres/sized_cost_function.h>

#include <atomic>
#include <cstddef>
#include <span>
#include <vector>

#include "porta/slam/pose.hpp"

namespace porta::slam::optim {

struct PoseGraphVertex {
  SE3 T_cw = SE3::Identity();  ///< world -> camera; the initial estimate
  bool fixed = false;
};

/// Relative-pose constraint between vertices i and j: the measured T_ij = T_iw * T_jw^-1 (maps
/// camera-j coordinates into camera i).
struct PoseGraphEdge {
  std::size_t i = 0, j = 0;
  SE3 T_ij = SE3::Identity();
  double weight = 1.0;  ///< information = weight * I6; finite and > 0
};

struct PoseGraphOptions {
  int iterations = 20;  ///< maximum Levenberg-Marquardt iterations, >= 1
  int num_threads = 1;  ///< >= 1; 1 gives bit-identical reruns
  /// When set (e.g. a new loop or a reset request) the solver stops at its next iteration.
  const std::atomic<bool>* stop_flag = nullptr;
};

struct PoseGraphResult {
  std::vector<SE3> T_cw;      ///< every vertex; fixed and edge-less ones are copies of the input
  double initial_cost = 0.0;  ///< Ceres cost 1/2 sum |r|^2 at the input
  double final_cost = 0.0;    ///< Ceres cost at the returned poses
  int iterations = 0;         ///< LM iterations as Ceres counts them (the initial evaluation is one)
  double time_s = 0.0;
  bool stopped = false;  ///< the stop flag cut the optimisation short
};

/// Throws std::invalid_argument naming the problem for an edge naming a vertex that does not exist,
/// an edge with i == j, a weight <= 0 or not finite, a non-finite pose, iterations < 1 or
/// num_threads < 1; std::runtime_error (with Ceres' message) if Ceres reports an unusable solution.
PoseGraphResult optimize_pose_graph(std::span<const PoseGraphVertex> vertices,
                                    std::span<const PoseGraphEdge> edges,
                                    const PoseGraphOptions& options = {});

/// The residual of one edge: 6 residuals [phi; rho]; parameters: T_iw (7), T_jw (7). Jacobians are
/// the true derivatives with respect to the 7 ambient parameters of each pose (the quaternion is
/// normalised, as params_to_pose), chained by Ceres through Se3Manifold::PlusJacobian.
class RelativePoseCost final : public ceres::SizedCostFunction<6, 7, 7> {
 public:
  RelativePoseCost(const SE3& T_ij, double weight);
  bool Evaluate(const double* const* parameters, double* residuals, double** jacobians) const override;

 private:
  SE3 T_ji_;  ///< the measurement inverted once: T_ij^-1
  double sqrt_weight_;
};

}  // namespace porta::slam::optim
