// SE(3) pose-graph optimisation on Ceres with an analytic relative-pose residual; see pose_graph.hpp.
#include "porta/slam/optim/pose_graph.hpp"

#include <ceres/iteration_callback.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <ceres/types.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "porta/slam/optim/se3_manifold.hpp"
#include "solver_setup.hpp"

namespace porta::slam::optim {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// c(theta) of V(phi)^-1 = I - K/2 + c K^2 (K = [phi]x), the same function se3_log applies (its
// helper is private to se3_manifold.cpp); below 1e-2 rad the Taylor series avoids the cancellation.
double inverse_v_c(double theta2) {
  if (theta2 < 1e-4) return 1.0 / 12.0 + theta2 / 720.0 + theta2 * theta2 / 30240.0;
  const double half = 0.5 * std::sqrt(theta2);
  return (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
}

// (dc/dtheta) / theta, which the derivative of V(phi)^-1 along phi needs. The closed form loses
// ~eps / theta^4 to cancellation, so below 0.3 rad the Taylor series (through theta^8, relative
// error < 1e-12 there) is used instead.
double inverse_v_c_rate(double theta2) {
  if (theta2 < 0.09) {
    return 1.0 / 360.0 +
           theta2 * (1.0 / 7560.0 + theta2 * (1.0 / 201600.0 +
                                              theta2 * (1.0 / 5987520.0 + theta2 * 691.0 / 130767436800.0)));
  }
  const double theta = std::sqrt(theta2);
  const double half = 0.5 * theta;
  const double sin_half = std::sin(half);
  const double cot_half = std::cos(half) / sin_half;
  const double c = (1.0 - half * cot_half) / theta2;
  return (half / (sin_half * sin_half) - cot_half) / (2.0 * theta2 * theta) - 2.0 * c / theta2;
}

// d log(exp(eps) E) / d eps at eps = [a; b] = 0, for E with log xi = [phi; rho] and translation t.
// exp(eps) E has rotation Exp(a) R and translation ~ t - [t]x a + b, so phi moves by V(phi)^-1 a
// (SO(3)'s inverse left Jacobian) and rho = V(phi)^-1 t by D dphi + V(phi)^-1 (b - [t]x a), where
// D = d(V(phi)^-1 t)/d phi, from V^-1 t = t - phi x t / 2 + c(theta) phi x (phi x t).
Mat6 log_left_jacobian(const Vec6& xi, const Vec3& t) {
  const Vec3 phi = xi.head<3>();
  const double theta2 = phi.squaredNorm();
  const double c = inverse_v_c(theta2);
  const Mat3 K = skew(phi);
  const Mat3 V_inv = Mat3::Identity() - 0.5 * K + c * K * K;
  // phi x (phi x t) = phi (phi.t) - t |phi|^2, differentiated; dc/dphi = (dc/dtheta / theta) phi^T.
  const Mat3 D = 0.5 * skew(t) +
                 c * (phi.dot(t) * Mat3::Identity() + phi * t.transpose() - 2.0 * t * phi.transpose()) +
                 inverse_v_c_rate(theta2) * (K * (K * t)) * phi.transpose();
  Mat6 L = Mat6::Zero();
  L.topLeftCorner<3, 3>() = V_inv;
  L.bottomLeftCorner<3, 3>() = D * V_inv - V_inv * skew(t);
  L.bottomRightCorner<3, 3>() = V_inv;
  return L;
}

// Ad_T in the tangent order [phi; rho]: T exp(xi) T^-1 = exp(Ad_T xi).
Mat6 adjoint(const SE3& T) {
  const Mat3 R = T.linear();
  Mat6 A = Mat6::Zero();
  A.topLeftCorner<3, 3>() = R;
  A.bottomLeftCorner<3, 3>() = skew(T.translation()) * R;
  A.bottomRightCorner<3, 3>() = R;
  return A;
}

// The residual depends on q only through q/|q|, so its ambient Jacobian is the tangent (left
// increment) Jacobian times MinusJacobian at the normalised pose (MinusJacobian * PlusJacobian = I),
// with the quaternion columns divided by |q|.
void write_ambient_jacobian(const Mat6& J_tangent, const double* pose, double* jacobian) {
  Eigen::Matrix<double, 6, 7, Eigen::RowMajor> minus_jacobian;
  Se3Manifold().MinusJacobian(pose, minus_jacobian.data());
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J = J_tangent * minus_jacobian;
  J.leftCols<4>() /= Eigen::Map<const Eigen::Vector4d>(pose).norm();
}

/// Ends the solve at the next iteration once the caller's flag is set.
class StopOnFlag final : public ceres::IterationCallback {
 public:
  explicit StopOnFlag(const std::atomic<bool>* flag) : flag_(flag) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return flag_->load(std::memory_order_relaxed) ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                                  : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* flag_;
};

void validate_input(std::span<const PoseGraphVertex> vertices, std::span<const PoseGraphEdge> edges,
                    const PoseGraphOptions& options) {
  const std::string fn = "optimize_pose_graph: ";
  if (options.iterations < 1) {
    throw std::invalid_argument(fn + "options.iterations = " + std::to_string(options.iterations) +
                                " (must be >= 1)");
  }
  if (options.num_threads < 1) {
    throw std::invalid_argument(fn + "options.num_threads = " + std::to_string(options.num_threads) +
                                " (must be >= 1)");
  }
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    if (!vertices[k].T_cw.matrix().allFinite()) {
      throw std::invalid_argument(fn + "vertex " + std::to_string(k) + " has a non-finite T_cw");
    }
  }
  const std::size_t n = vertices.size();
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const PoseGraphEdge& edge = edges[e];
    const std::string where = fn + "edge " + std::to_string(e);
    for (const std::size_t v : {edge.i, edge.j}) {
      if (v >= n) {
        throw std::invalid_argument(where + " names vertex " + std::to_string(v) + " but there are " +
                                    std::to_string(n) + " vertices");
      }
    }
    if (edge.i == edge.j) {
      throw std::invalid_argument(where + " joins vertex " + std::to_string(edge.i) + " to itself (i == j)");
    }
    if (!(edge.weight > 0.0) || !std::isfinite(edge.weight)) {
      throw std::invalid_argument(where + " has weight " + std::to_string(edge.weight) +
                                  " (must be finite and > 0)");
    }
    if (!edge.T_ij.matrix().allFinite()) throw std::invalid_argument(where + " has a non-finite T_ij");
  }
}

}  // namespace

RelativePoseCost::RelativePoseCost(const SE3& T_ij, double weight)
    : T_ji_(T_ij.inverse()), sqrt_weight_(std::sqrt(weight)) {}

bool RelativePoseCost::Evaluate(const double* const* parameters, double* residuals,
                                double** jacobians) const {
  const SE3 T_iw = params_to_pose(parameters[0]);
  const SE3 T_jw = params_to_pose(parameters[1]);
  const SE3 E = T_ji_ * (T_iw * T_jw.inverse());
  const Vec6 xi = se3_log(E);
  Eigen::Map<Vec6> residual(residuals);
  residual = sqrt_weight_ * xi;
  if (jacobians == nullptr) return true;

  // Left increments: T_iw <- exp(d) T_iw turns E into exp(Ad(T_ij^-1) d) E, and T_jw <- exp(d) T_jw
  // turns it into E exp(-d) = exp(-Ad(E) d) E.
  const Mat6 L = sqrt_weight_ * log_left_jacobian(xi, E.translation());
  if (jacobians[0] != nullptr) write_ambient_jacobian(L * adjoint(T_ji_), parameters[0], jacobians[0]);
  if (jacobians[1] != nullptr) write_ambient_jacobian(-L * adjoint(E), parameters[1], jacobians[1]);
  return true;
}

PoseGraphResult optimize_pose_graph(std::span<const PoseGraphVertex> vertices,
                                    std::span<const PoseGraphEdge> edges, const PoseGraphOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  validate_input(vertices, edges, options);
  const std::size_t n = vertices.size();

  PoseGraphResult result;
  result.T_cw.reserve(n);
  for (const PoseGraphVertex& v : vertices) result.T_cw.push_back(v.T_cw);
  const auto elapsed_s = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  if (edges.empty()) {
    result.time_s = elapsed_s();
    return result;
  }

  // Only vertices with an edge enter the problem. Without a fixed one among them the graph could
  // slide as a whole, so the lowest-index one is held (the gauge).
  std::vector<bool> in_graph(n, false);
  for (const PoseGraphEdge& e : edges) in_graph[e.i] = in_graph[e.j] = true;
  std::vector<bool> held(n, false);
  bool anchored = false;
  for (std::size_t k = 0; k < n; ++k) {
    held[k] = in_graph[k] && vertices[k].fixed;
    anchored = anchored || held[k];
  }
  for (std::size_t k = 0; k < n && !anchored; ++k) {
    if (!in_graph[k]) continue;
    held[k] = true;
    anchored = true;
  }

  std::vector<PoseParams> params(n);
  std::vector<std::unique_ptr<RelativePoseCost>> costs;
  costs.reserve(edges.size());
  for (const PoseGraphEdge& e : edges) costs.push_back(std::make_unique<RelativePoseCost>(e.T_ij, e.weight));
  Se3Manifold manifold;
  ceres::Problem problem(detail::borrowing_problem_options());
  for (std::size_t k = 0; k < n; ++k) {  // in vertex order, independent of the edge order
    if (!in_graph[k]) continue;
    params[k] = pose_to_params(vertices[k].T_cw);
    problem.AddParameterBlock(params[k].data(), kPoseAmbientSize, &manifold);
    if (held[k]) problem.SetParameterBlockConstant(params[k].data());
  }
  for (std::size_t e = 0; e < edges.size(); ++e) {
    problem.AddResidualBlock(costs[e].get(), nullptr, params[edges[e].i].data(), params[edges[e].j].data());
  }

  ceres::Solver::Options solver_options =
      detail::quiet_solver_options(options.iterations, options.num_threads);
  // Debian's Ceres has SuiteSparse (and Eigen's sparse Cholesky), its default; a Ceres without any
  // sparse library solves the dense normal equations, still fine for a few hundred keyframes.
  const ceres::SparseLinearAlgebraLibraryType sparse = solver_options.sparse_linear_algebra_library_type;
  const bool has_sparse =
      sparse != ceres::NO_SPARSE && ceres::IsSparseLinearAlgebraLibraryTypeAvailable(sparse);
  solver_options.linear_solver_type =
      has_sparse ? ceres::SPARSE_NORMAL_CHOLESKY : ceres::DENSE_NORMAL_CHOLESKY;
  StopOnFlag stop_callback(options.stop_flag);
  if (options.stop_flag != nullptr) solver_options.callbacks.push_back(&stop_callback);

  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    throw std::runtime_error("optimize_pose_graph: Ceres failed: " + summary.message);
  }
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  // Ceres counts the initial evaluation as a step, and leaves both counts at -1 when nothing is free.
  result.iterations = std::max(0, summary.num_successful_steps) + std::max(0, summary.num_unsuccessful_steps);
  result.stopped = summary.termination_type == ceres::USER_SUCCESS;
  for (std::size_t k = 0; k < n; ++k) {
    if (in_graph[k] && !held[k]) result.T_cw[k] = params_to_pose(params[k].data());
  }
  result.time_s = elapsed_s();
  return result;
}

}  // namespace porta::slam::optim
