// Levenberg-Marquardt with per-point Schur elimination; see schur_solver.hpp.
//
// Normal equations of the damped step, poses c and points p:
//   [U  W ] [dc]   [-g_c]        U = sum w Jc^T Jc + mu D_c,   V = sum w Jp^T Jp + mu D_p,
//   [W^T V] [dp] = [-g_p],       W = sum w Jc^T Jp,            g = sum w J^T r.
// V is block diagonal (one 3x3 per point), so dp = V^-1 (-g_p - W^T dc) and
//   (U - W V^-1 W^T) dc = -g_c + W V^-1 g_p,
// a dense system of 6 x (free keyframes) unknowns, built point by point: every pair of a point's
// free observations adds one 6x6 block.
//
// The pose blocks are kept in the camera's frame. With p = R X + t the point in the camera, D = dr/dp
// (camera_residual), w the Huber weight and A = [-[p]x  I] (dp / d(phi, rho)): J_pose = D A and
// J_point = D R, so with M = w D^T D (3x3) and N = M R,
//   U += A^T M A,   g_c += A^T e (e = w D^T r),   W = A^T N,
// and a pair's block of the reduction, W_a V^-1 W_c^T = A_a^T (C_a N_c^T) A_c with C_a = N_a V^-1:
// 3x3 products, then cross products with p_a and p_c, instead of 6x3 by 3x6 ones.
//
// Two ways to build it, the same numbers in the same order (so the same bits): on one thread, one
// sweep over the points does everything (the fastest there); with a parallel_for, the work is
// split by point (Jacobians, V^-1, the points' steps), by free keyframe (U, g_c, b) and by block
// of the reduced system, each adding its terms in the sweep's order (schur_layout.hpp).
#include "schur_solver.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>

#include "huber_weight.hpp"
#include "schur_layout.hpp"

namespace porta::slam::optim::detail {
namespace {

using Vec3 = Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;

// Ceres' Levenberg-Marquardt constants (ceres::Solver::Options defaults).
constexpr double kInitialRadius = 1e4;
constexpr double kMaxRadius = 1e16;
constexpr double kMinDiagonal = 1e-6;
constexpr double kMaxDiagonal = 1e32;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kParameterTolerance = 1e-8;
constexpr double kGradientTolerance = 1e-10;
/// A point's damped block is invertible when det / (product of its diagonal) is above this.
constexpr double kMinRelativeDeterminant = 1e-12;

double delta2(const SchurStage& stage, std::size_t i) {
  return stage.observations[i].is_stereo() ? stage.chi2_stereo : stage.chi2_mono;
}

/// One observation's residual (3 rows; the third is 0 for mono) and its squared norm, at camera
/// point p; with dr_dp, the derivative (third row 0 for mono).
[[gnu::always_inline]] inline bool residual_at(const SchurStage& stage, std::size_t i, const Vec3& p, Vec3& r, Mat3* dr_dp) {
  const BaObservation& o = stage.observations[i];
  const double s = stage.sqrt_information[i];
  r.setZero();
  if (o.is_stereo()) {
    const double observation[3] = {o.u_left, o.v, o.u_right};
    return camera_residual<3>(stage.model, observation, s, p, r.data(), dr_dp);
  }
  const double observation[2] = {o.u_left, o.v};
  Eigen::Matrix<double, 2, 3> d2;
  if (!camera_residual<2>(stage.model, observation, s, p, r.data(), dr_dp == nullptr ? nullptr : &d2))
    return false;
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

/// Observation i of world point X, linearised: residual, Huber weight and, for a fixed keyframe,
/// the derivative by the point; for a free keyframe, the camera-frame factors instead (the point in
/// the camera p, M = w D^T D, e = w D^T r and N = M R; see the top of this file). False when the
/// point lies in the camera's plane.
struct Linearised {
  Vec3 r;
  double w = 0.0;
  Mat3 J_point;  // fixed keyframe only
  Vec3 p, e;     // free keyframe only
  Mat3 M, N;
};
bool linearise_observation(const SchurStage& stage, std::size_t i, const Mat3& R, const PoseParams& x,
                           const Vec3& X, bool free_pose, Linearised& l) {
  const Vec3 p = R * X + Vec3(x[4], x[5], x[6]);
  Mat3 D;
  if (!residual_at(stage, i, p, l.r, &D)) return false;
  l.w = huber_weight(l.r.squaredNorm(), delta2(stage, i), stage.robust).weight;
  if (!free_pose) {
    l.J_point.noalias() = D * R;
    return true;
  }
  // camera_residual's D has zeros at (0, 1), (1, 0), (2, 1) and D(2, 0) = D(0, 0) (the third row is
  // all zero for a mono observation): M's (0, 1) entry is 0.
  const double w = l.w;
  const double d00 = D(0, 0), d02 = D(0, 2), d11 = D(1, 1), d12 = D(1, 2), d20 = D(2, 0), d22 = D(2, 2);
  l.M(0, 0) = w * (d00 * d00 + d20 * d20);
  l.M(1, 1) = w * (d11 * d11);
  l.M(2, 2) = w * (d02 * d02 + d12 * d12 + d22 * d22);
  l.M(0, 1) = l.M(1, 0) = 0.0;
  l.M(0, 2) = l.M(2, 0) = w * (d00 * d02 + d20 * d22);
  l.M(1, 2) = l.M(2, 1) = w * (d11 * d12);
  l.e = Vec3(w * (d00 * l.r[0] + d20 * l.r[2]), w * (d11 * l.r[1]), w * (d02 * l.r[0] + d12 * l.r[1] + d22 * l.r[2]));
  l.N.noalias() = l.M * R;
  l.p = p;
  return true;
}

/// A point's terms from one observation: V += J_point^T w J_point, g_p += J_point^T w r (for a free
/// keyframe from its factors: R^T N and R^T e).
[[gnu::always_inline]] inline void add_point_terms(const Linearised& l, bool free_pose, const Mat3& R, Mat3& V, Vec3& g) {
  if (free_pose) {
    V.noalias() += R.transpose() * l.N;
    g.noalias() += R.transpose() * l.e;
  } else {
    V.noalias() += l.w * l.J_point.transpose() * l.J_point;
    g.noalias() += l.w * l.J_point.transpose() * l.r;
  }
}

/// A free observation's factors, as the keyframes' sums take them.
struct PoseRow {
  Vec3 p, e;
  Mat3 M;
};
/// U += A^T M A and g += A^T e for A = [-[p]x  I]:
///   A^T M A = [ -K [p]x   K ]   with K = [p]x M (so -M [p]x = K^T),   A^T e = [ p x e ]
///             [  K^T      M ]                                                 [   e   ].
[[gnu::always_inline]] inline void add_pose_terms(const Vec3& p, const Mat3& M, const Vec3& e, Mat6& U, Vec6& g) {
  Mat3 K;
  for (int c = 0; c < 3; ++c) K.col(c) = p.cross(M.col(c));
  // -K [p]x, row by row: -k^T [p]x = (p x k)^T.
  for (int r = 0; r < 3; ++r) U.block<1, 3>(r, 0) += p.cross(K.row(r).transpose()).transpose();
  U.topRightCorner<3, 3>() += K;
  U.bottomLeftCorner<3, 3>() += K.transpose();
  U.bottomRightCorner<3, 3>() += M;
  g.head<3>() += p.cross(e);
  g.tail<3>() += e;
}

/// A_a^T Q A_c for A = [-[p]x  I] (the block a pair of a point's observations takes from the
/// reduced system, with Q = C_a N_c^T):
///   [ -P [p_c]x   P ]   with P = [p_a]x Q.
///   [ -Q [p_c]x   Q ]
[[gnu::always_inline]] inline Mat6 pair_block(const Vec3& p_a, const Mat3& Q, const Vec3& p_c) {
  Mat6 out;
  Mat3 P;
  for (int c = 0; c < 3; ++c) P.col(c) = p_a.cross(Q.col(c));
  for (int r = 0; r < 3; ++r) {
    out.block<1, 3>(r, 0) = p_c.cross(P.row(r).transpose()).transpose();
    out.block<1, 3>(r + 3, 0) = p_c.cross(Q.row(r).transpose()).transpose();
  }
  out.topRightCorner<3, 3>() = P;
  out.bottomRightCorner<3, 3>() = Q;
  return out;
}

/// W_a V^-1 g_p = A_a^T (C_a g_p): a keyframe's part of the reduced system's right-hand side.
[[gnu::always_inline]] inline Vec6 rhs_term(const Vec3& p_a, const Mat3& C_a, const Vec3& g_p) {
  const Vec3 h = C_a * g_p;
  Vec6 out;
  out << p_a.cross(h), h;
  return out;
}

/// The solver's arrays, kept by each thread that solves from one solve to the next: a window's
/// ~10 MB, allocated anew per stage, cost more in page faults (serialised in the kernel when the
/// split loops touch it first on many threads) than the arithmetic of a whole iteration.
struct Buffers {
  std::vector<Mat3> R;
  std::vector<Mat3> N, C;  // per slot: M R and N V^-1 (free slots only)
  std::vector<Vec3> P;     // per slot: the point in the camera (free slots only)
  std::vector<Mat3> V, V_inv;
  std::vector<Vec3> g_p, step_p;
  std::vector<Mat6> U;
  std::vector<Vec6> g_c;
  std::vector<double> cost;
  std::vector<PoseRow> pose_rows;
  Eigen::VectorXd step_c, b;
  Eigen::MatrixXd S;
};
Buffers& thread_buffers() {
  thread_local Buffers buffers;
  return buffers;
}

class Solver {
 public:
  Solver(const SchurStage& stage, std::vector<PoseParams>& poses, std::vector<Vec3>& points, Buffers& buffers)
      : stage_(stage),
        poses_(poses),
        points_(points),
        parallel_(stage.parallel_for != nullptr && *stage.parallel_for),
        layout_(make_schur_layout(stage.observations, *stage.active, *stage.pose_fixed, points.size(), parallel_)),
        R_(buffers.R),
        N_(buffers.N),
        P_(buffers.P),
        V_(buffers.V),
        V_inv_(buffers.V_inv),
        g_p_(buffers.g_p),
        step_p_(buffers.step_p),
        U_(buffers.U),
        g_c_(buffers.g_c),
        cost_(buffers.cost),
        step_c_(buffers.step_c),
        b_(buffers.b),
        S_(buffers.S),
        pose_rows_(buffers.pose_rows),
        C_(buffers.C) {
    const std::size_t n_slots = layout_.observations.size();
    const auto n_points = layout_.points.size();
    const auto n_free = static_cast<std::size_t>(layout_.free_keyframes);
    N_.resize(n_slots);
    P_.resize(n_slots);
    cost_.resize(n_slots);
    if (parallel_) {
      C_.resize(n_slots);
      pose_rows_.resize(layout_.keyframe_slots.size());
    }
    V_.resize(n_points);
    V_inv_.resize(n_points);
    g_p_.resize(n_points);
    U_.resize(n_free);
    g_c_.resize(n_free);
    step_c_.resize(6 * static_cast<Eigen::Index>(n_free));
    b_.resize(6 * static_cast<Eigen::Index>(n_free));
    step_p_.resize(n_points);
    S_.resize(6 * static_cast<Eigen::Index>(n_free), 6 * static_cast<Eigen::Index>(n_free));
  }

  SchurSummary run();

 private:
  /// fn(i) for every i in [0, n): on the stage's parallel_for when it has one.
  template <typename Fn>
  void for_each_index(std::size_t n, Fn&& fn) const {
    if (!parallel_ || n < 2) {
      for (std::size_t i = 0; i < n; ++i) fn(i);
      return;
    }
    (*stage_.parallel_for)(static_cast<std::int64_t>(n),
                           [&fn](std::int64_t i) { fn(static_cast<std::size_t>(i)); });
  }
  Mat3 damped(Mat3 H, double mu) const;
  bool cost_at(const std::vector<PoseParams>& poses, const std::vector<Vec3>& points, double& cost);
  bool linearise();
  bool linearise_split();
  bool invert_point(std::size_t j, double mu);
  bool solve_step(double mu);
  void reduce_in_one_sweep();
  void reduce_split();
  bool back_substitute();
  double max_gradient() const;

  const SchurStage& stage_;
  std::vector<PoseParams>& poses_;
  std::vector<Vec3>& points_;
  const bool parallel_;
  const SchurLayout layout_;
  // In the thread's Buffers.
  std::vector<Mat3>& R_;
  // Linearisation at the current estimate (undamped). W = A^T N per free slot, kept as N and p.
  std::vector<Mat3>& N_;
  std::vector<Vec3>& P_;
  std::vector<Mat3>& V_;
  std::vector<Mat3>& V_inv_;
  std::vector<Vec3>& g_p_;
  std::vector<Vec3>& step_p_;
  std::vector<Mat6>& U_;
  std::vector<Vec6>& g_c_;
  std::vector<double>& cost_;  // per slot, summed in slot order
  // The reduced system S (upper triangle) and its side b.
  Eigen::VectorXd& step_c_;
  Eigen::VectorXd& b_;
  Eigen::MatrixXd& S_;
  // Split work only: the free slots' pose rows in keyframe order; C = N V^-1 per free slot.
  std::vector<PoseRow>& pose_rows_;
  std::vector<Mat3>& C_;
};

Mat3 Solver::damped(Mat3 H, double mu) const {
  for (int d = 0; d < 3; ++d) H(d, d) += mu * std::clamp(H(d, d), kMinDiagonal, kMaxDiagonal);
  return H;
}

bool Solver::cost_at(const std::vector<PoseParams>& poses, const std::vector<Vec3>& points, double& cost) {
  rotations(poses, R_);
  std::atomic<bool> ok{true};
  for_each_index(layout_.points.size(), [&](std::size_t j) {
    const Vec3& X = points[layout_.points[j]];
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      const std::size_t i = layout_.observations[a];
      const std::size_t k = stage_.observations[i].keyframe;
      const PoseParams& x = poses[k];
      const Vec3 p = R_[k] * X + Vec3(x[4], x[5], x[6]);
      Vec3 r;
      if (!residual_at(stage_, i, p, r, nullptr)) {
        ok.store(false, std::memory_order_relaxed);
        return;
      }
      cost_[a] = huber_weight(r.squaredNorm(), delta2(stage_, i), stage_.robust).cost;
    }
  });
  if (!ok.load()) return false;
  cost = 0.0;
  for (const double c : cost_) cost += c;
  return std::isfinite(cost);
}

bool Solver::linearise() {
  rotations(poses_, R_);
  if (parallel_) return linearise_split();
  for (Mat6& U : U_) U.setZero();
  for (Vec6& g : g_c_) g.setZero();
  Linearised l;
  for (std::size_t j = 0; j < layout_.points.size(); ++j) {
    const Vec3& X = points_[layout_.points[j]];
    Mat3 V = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      const std::size_t i = layout_.observations[a];
      const std::size_t k = stage_.observations[i].keyframe;
      const int f = layout_.free_of[a];
      if (!linearise_observation(stage_, i, R_[k], poses_[k], X, f >= 0, l)) return false;
      add_point_terms(l, f >= 0, R_[k], V, g);
      if (f < 0) continue;
      add_pose_terms(l.p, l.M, l.e, U_[static_cast<std::size_t>(f)], g_c_[static_cast<std::size_t>(f)]);
      N_[a] = l.N;
      P_[a] = l.p;
    }
    V_[j] = V;
    g_p_[j] = g;
  }
  return true;
}

bool Solver::linearise_split() {
  std::atomic<bool> ok{true};
  // By point: V, g_p, W and the pose rows.
  for_each_index(layout_.points.size(), [&](std::size_t j) {
    const Vec3& X = points_[layout_.points[j]];
    Mat3 V = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    Linearised l;
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      const std::size_t i = layout_.observations[a];
      const std::size_t k = stage_.observations[i].keyframe;
      const int f = layout_.free_of[a];
      if (!linearise_observation(stage_, i, R_[k], poses_[k], X, f >= 0, l)) {
        ok.store(false, std::memory_order_relaxed);
        return;
      }
      add_point_terms(l, f >= 0, R_[k], V, g);
      if (f < 0) continue;
      pose_rows_[layout_.keyframe_position[a]] = {l.p, l.e, l.M};
      N_[a] = l.N;
      P_[a] = l.p;
    }
    V_[j] = V;
    g_p_[j] = g;
  });
  if (!ok.load()) return false;
  // By free keyframe: U and g_c over its rows in slot order.
  for_each_index(U_.size(), [&](std::size_t f) {
    Mat6 U = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    for (std::size_t s = layout_.keyframe_begin[f]; s < layout_.keyframe_begin[f + 1]; ++s) {
      add_pose_terms(pose_rows_[s].p, pose_rows_[s].M, pose_rows_[s].e, U, g);
    }
    U_[f] = U;
    g_c_[f] = g;
  });
  return true;
}

double Solver::max_gradient() const {
  double m = 0.0;
  for (const Vec6& g : g_c_) m = std::max(m, g.lpNorm<Eigen::Infinity>());
  for (const Vec3& g : g_p_) m = std::max(m, g.lpNorm<Eigen::Infinity>());
  return m;
}

/// V^-1 of point j's damped block; false when it is singular.
bool Solver::invert_point(std::size_t j, double mu) {
  // The test is relative to the block's scale (V of a distant point is small, its determinant
  // tiny): for a positive definite V, det <= V00 V11 V22 (Hadamard), and the ratio falls towards 0
  // as V nears singular. Eigen's computeInverseWithCheck compares det with an absolute 1e-12, and
  // refused far points whose V is invertible (det ~1e-15 at diagonals of ~1e-2 and ~1e-4): each
  // refusal failed the whole step, as if the reduced system were singular.
  const Mat3 H = damped(V_[j], mu);
  const double det = H.determinant();
  if (!(det > kMinRelativeDeterminant * H(0, 0) * H(1, 1) * H(2, 2))) return false;
  V_inv_[j] = H.inverse();
  return V_inv_[j].allFinite();
}

// The damped step into step_c_ / step_p_; false when the reduced system is not positive definite.
bool Solver::solve_step(double mu) {
  S_.setZero();
  for (std::size_t f = 0; f < U_.size(); ++f) {
    const auto o = 6 * static_cast<Eigen::Index>(f);
    Mat6 U = U_[f];
    for (int d = 0; d < 6; ++d) U(d, d) += mu * std::clamp(U(d, d), kMinDiagonal, kMaxDiagonal);
    S_.block<6, 6>(o, o) = U;
    b_.segment<6>(o) = -g_c_[f];
  }
  // V^-1 per point, and (split) its C = N V^-1 in the same pass.
  std::atomic<bool> ok{true};
  for_each_index(layout_.points.size(), [&](std::size_t j) {
    if (!invert_point(j, mu)) {
      ok.store(false, std::memory_order_relaxed);
      return;
    }
    if (!parallel_) return;
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      if (layout_.free_of[a] >= 0) C_[a].noalias() = N_[a] * V_inv_[j];
    }
  });
  if (!ok.load()) return false;
  if (parallel_) {
    reduce_split();
  } else {
    reduce_in_one_sweep();
  }
  if (S_.rows() > 0) {
    const Eigen::LLT<Eigen::MatrixXd, Eigen::Upper> llt(S_);
    if (llt.info() != Eigen::Success) return false;
    step_c_ = llt.solve(b_);
    if (!step_c_.allFinite()) return false;
  }
  return back_substitute();
}

// S -= W V^-1 W^T and b += W V^-1 g_p, point by point.
void Solver::reduce_in_one_sweep() {
  std::vector<Mat3> C;  // N V^-1 of the point's free observations
  std::vector<Eigen::Index> at;
  for (std::size_t j = 0; j < layout_.points.size(); ++j) {
    C.clear();
    at.clear();
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      const int f = layout_.free_of[a];
      if (f < 0) continue;
      C.push_back(N_[a] * V_inv_[j]);
      at.push_back(6 * static_cast<Eigen::Index>(f));
      b_.segment<6>(at.back()) += rhs_term(P_[a], C.back(), g_p_[j]);
    }
    std::size_t m = 0;
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      if (layout_.free_of[a] < 0) continue;
      // Upper triangle of S: the block (row, col) with row <= col.
      S_.block<6, 6>(at[m], at[m]) -= pair_block(P_[a], C[m] * N_[a].transpose(), P_[a]);
      std::size_t q = m + 1;
      for (std::size_t c = a + 1; c < layout_.group_begin[j + 1]; ++c) {
        if (layout_.free_of[c] < 0) continue;
        if (at[m] < at[q]) {
          S_.block<6, 6>(at[m], at[q]) -= pair_block(P_[a], C[m] * N_[c].transpose(), P_[c]);
        } else if (at[m] > at[q]) {
          S_.block<6, 6>(at[q], at[m]) -= pair_block(P_[c], C[q] * N_[a].transpose(), P_[a]);
        } else {  // two observations of one point in one keyframe: both cross terms
          S_.block<6, 6>(at[m], at[m]) -= pair_block(P_[a], C[m] * N_[c].transpose(), P_[c]) +
                                          pair_block(P_[c], C[q] * N_[a].transpose(), P_[a]);
        }
        ++q;
      }
      ++m;
    }
  }
}

// The same sums, split (C is ready): each block of S and each keyframe's part of b on its own.
void Solver::reduce_split() {
  const std::size_t blocks = layout_.blocks.size();
  for_each_index(blocks + U_.size(), [&](std::size_t t) {
    if (t >= blocks) {
      const std::size_t f = t - blocks;
      auto b = b_.segment<6>(6 * static_cast<Eigen::Index>(f));
      for (std::size_t s = layout_.keyframe_begin[f]; s < layout_.keyframe_begin[f + 1]; ++s) {
        const std::uint32_t a = layout_.keyframe_slots[s];
        b += rhs_term(P_[a], C_[a], g_p_[layout_.point_of[a]]);
      }
      return;
    }
    const SchurLayout::Block& block = layout_.blocks[t];
    auto block_of_S =
        S_.block<6, 6>(6 * static_cast<Eigen::Index>(block.row), 6 * static_cast<Eigen::Index>(block.col));
    // The same subtractions in the same order, on a contiguous copy (registers, not S's columns).
    Mat6 S = block_of_S;
    const SchurLayout::Term* const end = layout_.terms.data() + layout_.block_begin[t + 1];
    for (const SchurLayout::Term* term = layout_.terms.data() + layout_.block_begin[t]; term != end; ++term) {
      if (term + 1 != end) {  // the next term's rows: they lie wherever their point's slots are
        __builtin_prefetch(C_[term[1].x].data());
        __builtin_prefetch(N_[term[1].y].data());
      }
      const std::uint32_t x = term->x, y = term->y;
      if (term->both) {
        S -= pair_block(P_[x], C_[x] * N_[y].transpose(), P_[y]) + pair_block(P_[y], C_[y] * N_[x].transpose(), P_[x]);
      } else {
        S -= pair_block(P_[x], C_[x] * N_[y].transpose(), P_[y]);
      }
    }
    block_of_S = S;
  });
}

// The points' steps from the poses' one: dp = V^-1 (-g_p - W^T dc).
bool Solver::back_substitute() {
  std::atomic<bool> ok{true};
  for_each_index(layout_.points.size(), [&](std::size_t j) {
    Vec3 rhs = -g_p_[j];
    for (std::size_t a = layout_.group_begin[j]; a < layout_.group_begin[j + 1]; ++a) {
      const int f = layout_.free_of[a];
      if (f < 0) continue;
      // W^T dc = N^T A dc, A dc = rho - p x phi.
      const auto d = step_c_.segment<6>(6 * static_cast<Eigen::Index>(f));
      rhs.noalias() -= N_[a].transpose() * (d.tail<3>() - P_[a].cross(d.head<3>()));
    }
    step_p_[j] = V_inv_[j] * rhs;
    if (!step_p_[j].allFinite()) ok.store(false, std::memory_order_relaxed);
  });
  return ok.load();
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
          predicted += d[r] * (mu * std::clamp(U(r, r), kMinDiagonal, kMaxDiagonal) * d[r] -
                               g_c_[static_cast<std::size_t>(f)][r]);
        }
        step_sq += d.squaredNorm();
        for (int r = 0; r < 7; ++r)
          x_sq += poses_[k][static_cast<std::size_t>(r)] * poses_[k][static_cast<std::size_t>(r)];
      }
      for (std::size_t j = 0; j < layout_.points.size(); ++j) {
        const std::size_t p = layout_.points[j];
        const Vec3& d = step_p_[j];
        candidate_points[p] = points_[p] + d;
        for (int r = 0; r < 3; ++r)
          predicted += d[r] * (mu * std::clamp(V_[j](r, r), kMinDiagonal, kMaxDiagonal) * d[r] - g_p_[j][r]);
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
          converged = actual <= stage_.function_tolerance * cost;
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
  Solver solver(stage, poses, points, thread_buffers());
  return solver.run();
}

}  // namespace porta::slam::optim::detail
