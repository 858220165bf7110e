// Levenberg-Marquardt with per-point Schur elimination; see schur_solver.hpp.
//
// Normal equations of the damped step, poses c and points p:
//   [U  W ] [dc]   [-g_c]        U = sum w Jc^T Jc + mu D_c,   V = sum w Jp^T Jp + mu D_p,
//   [W^T V] [dp] = [-g_p],       W = sum w Jc^T Jp,            g = sum w J^T r.
// V is block diagonal (one 3x3 per point), so dp = V^-1 (-g_p - W^T dc) and
//   (U - W V^-1 W^T) dc = -g_c + W V^-1 g_p,
// a dense system of 6 x (free keyframes) unknowns, built point by point: every pair of a point's
// free observations adds one 6x6 block.
#include "schur_solver.hpp"
#include "huber_weight.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

namespace porta::slam::optim::detail {
namespace {

using Vec3 = Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Mat63 = Eigen::Matrix<double, 6, 3>;

// Ceres' Levenberg-Marquardt constants (ceres::Solver::Options defaults).
constexpr double kInitialRadius = 1e4;
constexpr double kMaxRadius = 1e16;
constexpr double kMinDiagonal = 1e-6;
constexpr double kMaxDiagonal = 1e32;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kFunctionTolerance = 1e-6;
constexpr double kParameterTolerance = 1e-8;
constexpr double kGradientTolerance = 1e-10;

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// The active observations grouped by point (point order, then input order).
struct Layout {
  std::vector<std::size_t> points;       // points with an active observation, ascending
  std::vector<std::size_t> group_begin;  // into `observations`, points.size() + 1 entries
  std::vector<std::size_t> observations;
  std::vector<int> free_index;  // per keyframe: its place among the free ones, -1 when fixed
  int free_keyframes = 0;
};

Layout make_layout(const SchurStage& stage, std::size_t num_keyframes, std::size_t num_points) {
  Layout layout;
  layout.free_index.assign(num_keyframes, -1);
  for (std::size_t k = 0; k < num_keyframes; ++k) {
    if (!(*stage.pose_fixed)[k]) layout.free_index[k] = layout.free_keyframes++;
  }
  std::vector<std::size_t> count(num_points, 0);
  for (std::size_t i = 0; i < stage.observations.size(); ++i) {
    if ((*stage.active)[i]) ++count[stage.observations[i].point];
  }
  std::vector<std::size_t> start(num_points, 0);
  layout.group_begin.push_back(0);
  for (std::size_t p = 0; p < num_points; ++p) {
    if (count[p] == 0) continue;
    start[p] = layout.group_begin.back();
    layout.points.push_back(p);
    layout.group_begin.push_back(start[p] + count[p]);
  }
  layout.observations.resize(layout.group_begin.back());
  for (std::size_t i = 0; i < stage.observations.size(); ++i) {
    if ((*stage.active)[i]) layout.observations[start[stage.observations[i].point]++] = i;
  }
  return layout;
}

/// One observation's residual (3 rows; the third is 0 for mono) and its squared norm, at camera
/// point p; with dr_dp, the derivative (third row 0 for mono).
bool residual_at(const SchurStage& stage, std::size_t i, const Vec3& p, Vec3& r, Mat3* dr_dp) {
  const BaObservation& o = stage.observations[i];
  const double s = stage.sqrt_information[i];
  r.setZero();
  if (o.is_stereo()) {
    const double observation[3] = {o.u_left, o.v, o.u_right};
    return camera_residual<3>(stage.model, observation, s, p, r.data(), dr_dp);
  }
  const double observation[2] = {o.u_left, o.v};
  Eigen::Matrix<double, 2, 3> d2;
  if (!camera_residual<2>(stage.model, observation, s, p, r.data(), dr_dp == nullptr ? nullptr : &d2)) return false;
  if (dr_dp != nullptr) {
    dr_dp->topRows<2>() = d2;
    dr_dp->row(2).setZero();
  }
  return true;
}

/// The rotation of every keyframe, once per evaluation instead of once per observation.
void rotations(const std::vector<PoseParams>& poses, std::vector<Mat3>& R) {
  R.resize(poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) R[k] = pose_rotation(poses[k].data());
}

class Solver {
 public:
  Solver(const SchurStage& stage, std::vector<PoseParams>& poses, std::vector<Vec3>& points)
      : stage_(stage), poses_(poses), points_(points), layout_(make_layout(stage, poses.size(), points.size())) {
    const std::size_t n_obs = layout_.observations.size();
    const auto n_points = layout_.points.size();
    const auto n_free = static_cast<std::size_t>(layout_.free_keyframes);
    W_.resize(n_obs);
    V_.resize(n_points);
    V_inv_.resize(n_points);
    g_p_.resize(n_points);
    U_.resize(n_free);
    g_c_.resize(n_free);
    step_c_.resize(6 * static_cast<Eigen::Index>(n_free));
    step_p_.resize(n_points);
    S_.resize(6 * static_cast<Eigen::Index>(n_free), 6 * static_cast<Eigen::Index>(n_free));
  }

  SchurSummary run();

 private:
  double delta2(std::size_t i) const {
    return stage_.observations[i].is_stereo() ? stage_.chi2_stereo : stage_.chi2_mono;
  }
  bool cost_at(const std::vector<PoseParams>& poses, const std::vector<Vec3>& points, double& cost);
  bool linearise();
  bool solve_step(double mu);
  double max_gradient() const;

  const SchurStage& stage_;
  std::vector<PoseParams>& poses_;
  std::vector<Vec3>& points_;
  const Layout layout_;
  std::vector<Mat3> R_;
  // Linearisation at the current estimate (undamped).
  std::vector<Mat63> W_;  // per grouped observation (zero for a fixed keyframe's)
  std::vector<Mat3> V_, V_inv_;
  std::vector<Vec3> g_p_, step_p_;
  std::vector<Mat6> U_;
  std::vector<Vec6> g_c_;
  Eigen::VectorXd step_c_;
  Eigen::MatrixXd S_;
};

bool Solver::cost_at(const std::vector<PoseParams>& poses, const std::vector<Vec3>& points, double& cost) {
  rotations(poses, R_);
  cost = 0.0;
  for (const std::size_t i : layout_.observations) {
    const BaObservation& o = stage_.observations[i];
    const PoseParams& x = poses[o.keyframe];
    const Vec3 p = R_[o.keyframe] * points[o.point] + Vec3(x[4], x[5], x[6]);
    Vec3 r;
    if (!residual_at(stage_, i, p, r, nullptr)) return false;
    cost += huber_weight(r.squaredNorm(), delta2(i), stage_.robust).cost;
  }
  return std::isfinite(cost);
}

bool Solver::linearise() {
  rotations(poses_, R_);
  for (Mat6& U : U_) U.setZero();
  for (Vec6& g : g_c_) g.setZero();
  for (std::size_t j = 0; j < layout_.points.size(); ++j) {
    const Vec3& X = points_[layout_.points[j]];
    Mat3 V = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      const std::size_t i = layout_.observations[a];
      const std::size_t k = stage_.observations[i].keyframe;
      const PoseParams& x = poses_[k];
      const Vec3 p = R_[k] * X + Vec3(x[4], x[5], x[6]);
      Vec3 r;
      Mat3 dr_dp;
      if (!residual_at(stage_, i, p, r, &dr_dp)) return false;
      const double w = huber_weight(r.squaredNorm(), delta2(i), stage_.robust).weight;
      const Mat3 J_point = dr_dp * R_[k];
      V.noalias() += w * J_point.transpose() * J_point;
      g.noalias() += w * J_point.transpose() * r;
      const int f = layout_.free_index[k];
      if (f < 0) {
        W_[a].setZero();
        continue;
      }
      // Left increment: p' = Exp(phi) p + V(phi) rho, so dp / d(phi, rho) = [-[p]x  I].
      Eigen::Matrix<double, 3, 6> J_pose;
      J_pose.leftCols<3>() = -dr_dp * skew(p);
      J_pose.rightCols<3>() = dr_dp;
      U_[static_cast<std::size_t>(f)].noalias() += w * J_pose.transpose() * J_pose;
      g_c_[static_cast<std::size_t>(f)].noalias() += w * J_pose.transpose() * r;
      W_[a].noalias() = w * J_pose.transpose() * J_point;
    }
    V_[j] = V;
    g_p_[j] = g;
  }
  return true;
}

double Solver::max_gradient() const {
  double m = 0.0;
  for (const Vec6& g : g_c_) m = std::max(m, g.lpNorm<Eigen::Infinity>());
  for (const Vec3& g : g_p_) m = std::max(m, g.lpNorm<Eigen::Infinity>());
  return m;
}

// The damped step into step_c_ / step_p_; false when the reduced system is not positive definite.
bool Solver::solve_step(double mu) {
  const auto damped = [mu](auto H) {
    for (int d = 0; d < H.rows(); ++d) H(d, d) += mu * std::clamp(H(d, d), kMinDiagonal, kMaxDiagonal);
    return H;
  };
  const Eigen::Index n = S_.rows();
  S_.setZero();
  Eigen::VectorXd b(n);
  for (std::size_t f = 0; f < U_.size(); ++f) {
    const auto o = 6 * static_cast<Eigen::Index>(f);
    S_.block<6, 6>(o, o) = damped(U_[f]);
    b.segment<6>(o) = -g_c_[f];
  }
  std::vector<Mat63> Y;  // W V^-1 of the point's free observations
  std::vector<Eigen::Index> at;
  for (std::size_t j = 0; j < layout_.points.size(); ++j) {
    const Mat3 V = damped(V_[j]);
    bool invertible = false;
    V.computeInverseWithCheck(V_inv_[j], invertible);
    if (!invertible || !V_inv_[j].allFinite()) return false;
    Y.clear();
    at.clear();
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      const int f = layout_.free_index[stage_.observations[layout_.observations[a]].keyframe];
      if (f < 0) continue;
      Y.push_back(W_[a] * V_inv_[j]);
      at.push_back(6 * static_cast<Eigen::Index>(f));
      b.segment<6>(at.back()).noalias() += Y.back() * g_p_[j];
    }
    std::size_t m = 0;
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      if (layout_.free_index[stage_.observations[layout_.observations[a]].keyframe] < 0) continue;
      const Mat63& Wa = W_[a];
      // Upper triangle of S: the block (row, col) with row <= col.
      S_.block<6, 6>(at[m], at[m]).noalias() -= Y[m] * Wa.transpose();
      std::size_t q = m + 1;
      for (std::size_t c = a + 1; c < layout_.group_begin[j + 1]; ++c) {
        if (layout_.free_index[stage_.observations[layout_.observations[c]].keyframe] < 0) continue;
        const Mat63& Wc = W_[c];
        if (at[m] < at[q]) {
          S_.block<6, 6>(at[m], at[q]).noalias() -= Y[m] * Wc.transpose();
        } else if (at[m] > at[q]) {
          S_.block<6, 6>(at[q], at[m]).noalias() -= Y[q] * Wa.transpose();
        } else {  // two observations of one point in one keyframe: both cross terms
          S_.block<6, 6>(at[m], at[m]).noalias() -= Y[m] * Wc.transpose() + Y[q] * Wa.transpose();
        }
        ++q;
      }
      ++m;
    }
  }
  if (n > 0) {
    const Eigen::LLT<Eigen::MatrixXd, Eigen::Upper> llt(S_);
    if (llt.info() != Eigen::Success) return false;
    step_c_ = llt.solve(b);
    if (!step_c_.allFinite()) return false;
  }
  for (std::size_t j = 0; j < layout_.points.size(); ++j) {
    Vec3 rhs = -g_p_[j];
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      const int f = layout_.free_index[stage_.observations[layout_.observations[a]].keyframe];
      if (f >= 0) rhs.noalias() -= W_[a].transpose() * step_c_.segment<6>(6 * static_cast<Eigen::Index>(f));
    }
    step_p_[j] = V_inv_[j] * rhs;
    if (!step_p_[j].allFinite()) return false;
  }
  return true;
}

SchurSummary Solver::run() {
  SchurSummary summary;
  if (layout_.observations.empty()) return summary;
  double cost = 0.0;
  if (!cost_at(poses_, points_, cost)) return summary;
  summary.ran = true;
  summary.initial_cost = summary.final_cost = cost;

  const Se3Manifold manifold;
  std::vector<PoseParams> candidate_poses = poses_;
  std::vector<Vec3> candidate_points = points_;
  double radius = kInitialRadius;
  double decrease_factor = 2.0;
  bool stale = true;  // the linearisation is of an older estimate
  while (summary.iterations < stage_.max_iterations) {
    if (stale) {
      if (!linearise()) break;
      stale = false;
      if (max_gradient() <= kGradientTolerance) break;
    }
    ++summary.iterations;
    const double mu = 1.0 / radius;
    bool kept = false;
    bool converged = false;
    if (solve_step(mu)) {
      // Candidate estimate, the step's size and the decrease the linear model predicts:
      // 1/2 step^T (mu D step - g).
      double step_sq = 0.0, x_sq = 0.0, predicted = 0.0;
      for (std::size_t k = 0; k < poses_.size(); ++k) {
        const int f = layout_.free_index[k];
        if (f < 0) continue;
        const Vec6 d = step_c_.segment<6>(6 * static_cast<Eigen::Index>(f));
        manifold.Plus(poses_[k].data(), d.data(), candidate_poses[k].data());
        const Mat6& U = U_[static_cast<std::size_t>(f)];
        for (int r = 0; r < 6; ++r) {
          predicted += d[r] * (mu * std::clamp(U(r, r), kMinDiagonal, kMaxDiagonal) * d[r] - g_c_[static_cast<std::size_t>(f)][r]);
        }
        step_sq += d.squaredNorm();
        for (int r = 0; r < 7; ++r) x_sq += poses_[k][static_cast<std::size_t>(r)] * poses_[k][static_cast<std::size_t>(r)];
      }
      for (std::size_t j = 0; j < layout_.points.size(); ++j) {
        const std::size_t p = layout_.points[j];
        const Vec3& d = step_p_[j];
        candidate_points[p] = points_[p] + d;
        for (int r = 0; r < 3; ++r) predicted += d[r] * (mu * std::clamp(V_[j](r, r), kMinDiagonal, kMaxDiagonal) * d[r] - g_p_[j][r]);
        step_sq += d.squaredNorm();
        x_sq += points_[p].squaredNorm();
      }
      predicted *= 0.5;
      if (std::sqrt(step_sq) <= kParameterTolerance * (std::sqrt(x_sq) + kParameterTolerance)) break;
      double candidate_cost = 0.0;
      if (predicted > 0.0 && cost_at(candidate_poses, candidate_points, candidate_cost)) {
        const double actual = cost - candidate_cost;
        if (actual / predicted > kMinRelativeDecrease) {
          const double rho = actual / predicted;
          radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3)));
          decrease_factor = 2.0;
          converged = actual <= kFunctionTolerance * cost;
          std::swap(poses_, candidate_poses);
          std::swap(points_, candidate_points);
          cost = candidate_cost;
          kept = true;
          stale = true;
        }
      }
    }
    if (!kept) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
    }
    if (stage_.between_iterations != nullptr && *stage_.between_iterations) (*stage_.between_iterations)();
    if (stage_.stop_flag != nullptr && stage_.stop_flag->load(std::memory_order_relaxed)) {
      summary.stopped = true;
      break;
    }
    if (converged) break;
  }
  summary.final_cost = cost;
  return summary;
}

}  // namespace

SchurSummary schur_levenberg_marquardt(const SchurStage& stage, std::vector<PoseParams>& poses,
                                       std::vector<Eigen::Vector3d>& points) {
  Solver solver(stage, poses, points);
  return solver.run();
}

}  // namespace porta::slam::optim::detail
