// SE(3) pose-graph optimisation (loop closing's essential graph): a ring of 100 keyframes built by
// biased dead reckoning must snap back onto the exact odometry and loop edges; an exact graph stays
// put; fixed vertices (and the gauge vertex) come back bit-identical; bad input is rejected by name;
// reruns repeat bit-for-bit; the stop flag is honoured; the edge residual's analytic Jacobians match
// central differences, on the 7 ambient parameters and through Se3Manifold.
#if PORTA_OPTIM_BUILT

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/slam/optim/pose_graph.hpp"
#include "porta/slam/optim/se3_manifold.hpp"

namespace porta::slam::optim {
namespace {

using Eigen::AngleAxisd;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;
using Vector6d = Eigen::Matrix<double, 6, 1>;

constexpr std::size_t kRingSize = 100;

bool same_bits(const SE3& a, const SE3& b) {
  return std::memcmp(a.matrix().data(), b.matrix().data(), sizeof(double) * 16) == 0;
}

double centre_error_m(const SE3& a, const SE3& b) {
  return (a.inverse().translation() - b.inverse().translation()).norm();
}

// T_cw of keyframes on a 10 m circle, heading along it, with a height wave and roll/pitch waves.
std::vector<SE3> ring_truth() {
  std::vector<SE3> T_cw;
  for (std::size_t k = 0; k < kRingSize; ++k) {
    const double a = 2.0 * std::numbers::pi * static_cast<double>(k) / kRingSize;
    SE3 T_wc = SE3::Identity();
    T_wc.linear() = (AngleAxisd(a + 0.5 * std::numbers::pi, Vector3d::UnitZ()) *
                     AngleAxisd(0.1 * std::sin(3.0 * a), Vector3d::UnitX()) *
                     AngleAxisd(0.05 * std::cos(2.0 * a), Vector3d::UnitY()))
                        .toRotationMatrix();
    T_wc.translation() = Vector3d(10.0 * std::cos(a), 10.0 * std::sin(a), 0.5 * std::sin(2.0 * a));
    T_cw.push_back(T_wc.inverse());
  }
  return T_cw;
}

PoseGraphEdge exact_edge(const std::vector<SE3>& T_cw, std::size_t i, std::size_t j) {
  return {i, j, T_cw[i] * T_cw[j].inverse(), 1.0};
}

// Odometry (k, k+1) and one loop edge from the last keyframe back to the first, all exact.
std::vector<PoseGraphEdge> ring_edges(const std::vector<SE3>& T_cw) {
  std::vector<PoseGraphEdge> edges;
  for (std::size_t k = 0; k + 1 < T_cw.size(); ++k) edges.push_back(exact_edge(T_cw, k, k + 1));
  edges.push_back(exact_edge(T_cw, T_cw.size() - 1, 0));
  return edges;
}

// Dead reckoning along the odometry edges with a bias of 0.3 degrees and ~1 cm per step, from the
// true first pose: the drift a tracker accumulates before the loop is detected.
std::vector<PoseGraphVertex> drifted_vertices(const std::vector<SE3>& truth,
                                              const std::vector<PoseGraphEdge>& edges) {
  SE3 bias = SE3::Identity();
  bias.linear() =
      AngleAxisd(0.3 * std::numbers::pi / 180.0, Vector3d(0.2, 0.3, 1.0).normalized()).toRotationMatrix();
  bias.translation() = Vector3d(0.01, -0.005, 0.003);
  std::vector<PoseGraphVertex> vertices{{truth[0], false}};
  for (std::size_t k = 0; k + 1 < truth.size(); ++k) {
    vertices.push_back({bias * edges[k].T_ij.inverse() * vertices[k].T_cw, false});
  }
  return vertices;
}

double max_centre_error_m(const std::vector<SE3>& T_cw, const std::vector<SE3>& truth) {
  double worst = 0.0;
  for (std::size_t k = 0; k < truth.size(); ++k) worst = std::max(worst, centre_error_m(T_cw[k], truth[k]));
  return worst;
}

double edge_residual_norm(const PoseGraphEdge& e, const std::vector<SE3>& T_cw) {
  return se3_log(e.T_ij.inverse() * T_cw[e.i] * T_cw[e.j].inverse()).norm();
}

std::vector<SE3> poses_of(const std::vector<PoseGraphVertex>& vertices) {
  std::vector<SE3> T;
  for (const PoseGraphVertex& v : vertices) T.push_back(v.T_cw);
  return T;
}

TEST(PoseGraph, ClosesDriftedLoop) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> edges = ring_edges(truth);
  const std::vector<PoseGraphVertex> vertices = drifted_vertices(truth, edges);
  const double initial_error = max_centre_error_m(poses_of(vertices), truth);
  const double initial_loop_residual = edge_residual_norm(edges.back(), poses_of(vertices));
  ASSERT_GT(initial_error, 2.0);
  ASSERT_GT(initial_loop_residual, 0.3);

  const PoseGraphResult r = optimize_pose_graph(vertices, edges);

  ASSERT_EQ(r.T_cw.size(), kRingSize);
  const double final_error = max_centre_error_m(r.T_cw, truth);
  EXPECT_LT(final_error, 0.1 * initial_error);
  // The edges are exact, so the truth is the optimum; Ceres' default tolerances stop within a few
  // micrometres of it (9 iterations from 5.3 m of drift).
  EXPECT_LT(final_error, 1e-4);
  EXPECT_LT(edge_residual_norm(edges.back(), r.T_cw), 1e-6);
  for (std::size_t k = 0; k < kRingSize; ++k) {
    EXPECT_LT(rotation_angle_rad(r.T_cw[k].linear() * truth[k].linear().transpose()), 1e-6) << k;
  }
  EXPECT_LT(r.final_cost, 1e-12 * r.initial_cost);
  EXPECT_GT(r.iterations, 0);
  EXPECT_LE(r.iterations, 20);
  EXPECT_GT(r.time_s, 0.0);
  EXPECT_FALSE(r.stopped);
}

TEST(PoseGraph, MultithreadedSolveReachesTheSameOptimum) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> edges = ring_edges(truth);
  PoseGraphOptions options;
  options.num_threads = 2;
  const PoseGraphResult r = optimize_pose_graph(drifted_vertices(truth, edges), edges, options);
  EXPECT_LT(max_centre_error_m(r.T_cw, truth), 1e-4);
}

TEST(PoseGraph, ExactGraphStaysPut) {
  const std::vector<SE3> truth = ring_truth();
  std::vector<PoseGraphVertex> vertices;
  for (const SE3& T : truth) vertices.push_back({T, false});
  const PoseGraphResult r = optimize_pose_graph(vertices, ring_edges(truth));
  EXPECT_LT(r.initial_cost, 1e-24);  // every residual vanishes, up to rounding
  EXPECT_LT(r.final_cost, 1e-24);
  for (std::size_t k = 0; k < kRingSize; ++k) {
    EXPECT_LT((r.T_cw[k].matrix() - truth[k].matrix()).cwiseAbs().maxCoeff(), 1e-12) << k;
  }
}

TEST(PoseGraph, FixedVerticesAndIsolatedOnesAreBitIdenticalCopies) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> edges = ring_edges(truth);
  std::vector<PoseGraphVertex> vertices = drifted_vertices(truth, edges);
  for (std::size_t k : {10u, 40u, 70u}) vertices[k].fixed = true;  // drifted: the rest must bend to them
  SE3 isolated = SE3::Identity();
  isolated.translation() = Vector3d(1.0, 2.0, 3.0);
  vertices.push_back({isolated, false});  // no edge: not part of the problem

  const PoseGraphResult r = optimize_pose_graph(vertices, edges);

  ASSERT_EQ(r.T_cw.size(), vertices.size());
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const bool copied = vertices[k].fixed || k == kRingSize;
    EXPECT_EQ(same_bits(r.T_cw[k], vertices[k].T_cw), copied) << k;
  }
  EXPECT_LT(r.final_cost, 0.1 * r.initial_cost);
}

TEST(PoseGraph, WithoutFixedVertexHoldsVertexZero) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> edges = ring_edges(truth);
  std::vector<PoseGraphVertex> vertices = drifted_vertices(truth, edges);
  SE3 offset = SE3::Identity();
  offset.translation() = Vector3d(0.5, 0.0, 0.0);
  vertices[0].T_cw = offset * vertices[0].T_cw;  // vertex 0 off the truth, and still the anchor

  const PoseGraphResult r = optimize_pose_graph(vertices, edges);

  EXPECT_TRUE(same_bits(r.T_cw[0], vertices[0].T_cw));
  for (std::size_t k = 1; k < kRingSize; ++k) EXPECT_FALSE(same_bits(r.T_cw[k], vertices[k].T_cw)) << k;
  EXPECT_LT(r.final_cost, 1e-12);  // the whole ring moved rigidly with its anchor
}

TEST(PoseGraph, AllVerticesFixedReturnsTheInput) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> edges = ring_edges(truth);
  std::vector<PoseGraphVertex> vertices = drifted_vertices(truth, edges);
  for (PoseGraphVertex& v : vertices) v.fixed = true;
  const PoseGraphResult r = optimize_pose_graph(vertices, edges);
  for (std::size_t k = 0; k < kRingSize; ++k) EXPECT_TRUE(same_bits(r.T_cw[k], vertices[k].T_cw)) << k;
  EXPECT_EQ(r.final_cost, r.initial_cost);
  EXPECT_EQ(r.iterations, 0);
}

// Runs the optimisation expecting std::invalid_argument with `hint` in its message.
void expect_rejected(const std::vector<PoseGraphVertex>& vertices, const std::vector<PoseGraphEdge>& edges,
                     const PoseGraphOptions& options, const std::string& hint) {
  try {
    optimize_pose_graph(vertices, edges, options);
    ADD_FAILURE() << "accepted; expected an error about: " << hint;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(hint), std::string::npos) << e.what();
  }
}

TEST(PoseGraph, RejectsInvalidInputByName) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> good_edges = ring_edges(truth);
  const std::vector<PoseGraphVertex> vertices = drifted_vertices(truth, good_edges);
  const auto with_edge_3 = [&](const std::function<void(PoseGraphEdge&)>& change) {
    std::vector<PoseGraphEdge> edges = good_edges;
    change(edges[3]);
    return edges;
  };
  const PoseGraphOptions defaults;
  expect_rejected(vertices, with_edge_3([](PoseGraphEdge& e) { e.j = kRingSize; }), defaults,
                  "edge 3 names vertex 100 but there are 100 vertices");
  expect_rejected(vertices, with_edge_3([](PoseGraphEdge& e) { e.i = 1000; }), defaults,
                  "edge 3 names vertex 1000");
  expect_rejected(vertices, with_edge_3([](PoseGraphEdge& e) { e.j = e.i; }), defaults,
                  "edge 3 joins vertex 3 to itself");
  for (double weight :
       {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    expect_rejected(vertices, with_edge_3([&](PoseGraphEdge& e) { e.weight = weight; }), defaults,
                    "edge 3 has weight");
  }
  expect_rejected(vertices, with_edge_3([](PoseGraphEdge& e) {
                    e.T_ij.translation().x() = std::numeric_limits<double>::quiet_NaN();
                  }),
                  defaults, "edge 3 has a non-finite T_ij");
  std::vector<PoseGraphVertex> bad_vertices = vertices;
  bad_vertices[7].T_cw.translation().y() = std::numeric_limits<double>::infinity();
  expect_rejected(bad_vertices, good_edges, defaults, "vertex 7 has a non-finite T_cw");
  PoseGraphOptions no_iterations;
  no_iterations.iterations = 0;
  expect_rejected(vertices, good_edges, no_iterations, "options.iterations = 0");
  PoseGraphOptions no_threads;
  no_threads.num_threads = 0;
  expect_rejected(vertices, good_edges, no_threads, "options.num_threads = 0");
}

TEST(PoseGraph, EmptyGraphReturnsTheInput) {
  const std::vector<PoseGraphVertex> vertices = {{SE3::Identity(), false}, {SE3::Identity(), true}};
  const PoseGraphResult r = optimize_pose_graph(vertices, {});
  ASSERT_EQ(r.T_cw.size(), 2u);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(r.final_cost, 0.0);
}

TEST(PoseGraph, RerunsAreBitIdentical) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> edges = ring_edges(truth);
  const std::vector<PoseGraphVertex> vertices = drifted_vertices(truth, edges);
  PoseGraphOptions options;
  options.iterations = 4;  // stop mid-way, where differences would still show
  const PoseGraphResult a = optimize_pose_graph(vertices, edges, options);
  const PoseGraphResult b = optimize_pose_graph(vertices, edges, options);
  ASSERT_EQ(a.T_cw.size(), b.T_cw.size());
  for (std::size_t k = 0; k < a.T_cw.size(); ++k) EXPECT_TRUE(same_bits(a.T_cw[k], b.T_cw[k])) << k;
  EXPECT_EQ(a.final_cost, b.final_cost);
  EXPECT_EQ(a.iterations, b.iterations);
}

TEST(PoseGraph, StopFlagSetBeforehandStopsAtOnce) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> edges = ring_edges(truth);
  const std::vector<PoseGraphVertex> vertices = drifted_vertices(truth, edges);
  std::atomic<bool> stop{true};
  PoseGraphOptions options;
  options.stop_flag = &stop;
  const PoseGraphResult r = optimize_pose_graph(vertices, edges, options);
  EXPECT_TRUE(r.stopped);
  EXPECT_LE(r.iterations, 1);
  EXPECT_GT(r.final_cost, 1e-3 * r.initial_cost);  // nowhere near the optimum yet
}

TEST(PoseGraph, StopFlagClearedRunsToTheEnd) {
  const std::vector<SE3> truth = ring_truth();
  const std::vector<PoseGraphEdge> edges = ring_edges(truth);
  const std::vector<PoseGraphVertex> vertices = drifted_vertices(truth, edges);
  std::atomic<bool> stop{false};
  PoseGraphOptions options;
  options.stop_flag = &stop;
  const PoseGraphResult with_flag = optimize_pose_graph(vertices, edges, options);
  const PoseGraphResult without = optimize_pose_graph(vertices, edges);
  EXPECT_FALSE(with_flag.stopped);
  EXPECT_EQ(with_flag.iterations, without.iterations);
  for (std::size_t k = 0; k < kRingSize; ++k) EXPECT_TRUE(same_bits(with_flag.T_cw[k], without.T_cw[k])) << k;
}

// ---- The edge residual ----------------------------------------------------------------------------

SE3 random_pose(std::mt19937& rng, double max_angle) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  SE3 T = SE3::Identity();
  T.linear() = AngleAxisd(max_angle * std::abs(u(rng)), Vector3d(u(rng), u(rng), u(rng)).normalized())
                   .toRotationMatrix();
  T.translation() = 3.0 * Vector3d(u(rng), u(rng), u(rng));
  return T;
}

MatrixXd numeric_jacobian(const std::function<VectorXd(const VectorXd&)>& f, const VectorXd& x, double h) {
  MatrixXd J(f(x).size(), x.size());
  for (int i = 0; i < x.size(); ++i) {
    VectorXd xp = x;
    VectorXd xm = x;
    xp[i] += h;
    xm[i] -= h;
    J.col(i) = (f(xp) - f(xm)) / (2.0 * h);
  }
  return J;
}

void expect_close(const MatrixXd& analytic, const MatrixXd& numeric, double tol, const std::string& what) {
  EXPECT_LE((analytic - numeric).norm(), tol * std::max(1.0, numeric.norm())) << what << "\nanalytic:\n"
                                                                              << analytic << "\nnumeric:\n"
                                                                              << numeric;
}

// Measurements that disagree with the poses by a rotation of `angle` (both sides of the series
// switches at 1e-2 and 0.3 rad, up to 2.5 rad) and a random translation.
TEST(PoseGraph, CostJacobiansMatchCentralDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Se3Manifold manifold;
  for (double angle : {0.0, 1e-7, 5e-3, 0.05, 0.29, 0.31, 1.0, 2.5}) {
    for (int trial = 0; trial < 4; ++trial) {
      const SE3 T_iw = random_pose(rng, 3.0);
      const SE3 T_jw = random_pose(rng, 3.0);
      Vector6d disagreement;
      disagreement << angle * Vector3d(u(rng), u(rng), u(rng)).normalized(), Vector3d(u(rng), u(rng), u(rng));
      const SE3 T_ij = T_iw * T_jw.inverse() * se3_exp(disagreement);
      const RelativePoseCost cost(T_ij, 2.0);
      const PoseParams xi = pose_to_params(T_iw);
      const PoseParams xj = pose_to_params(T_jw);
      SCOPED_TRACE(testing::Message() << "angle " << angle << " trial " << trial);

      Eigen::Matrix<double, 6, 7, Eigen::RowMajor> J[2];
      double* jacobians[] = {J[0].data(), J[1].data()};
      const double* params[] = {xi.data(), xj.data()};
      Vector6d r;
      ASSERT_TRUE(cost.Evaluate(params, r.data(), jacobians));
      EXPECT_LT((r - std::sqrt(2.0) * se3_log(T_ij.inverse() * T_iw * T_jw.inverse())).norm(), 1e-12);

      for (int side = 0; side < 2; ++side) {
        const PoseParams& x = side == 0 ? xi : xj;
        const auto residual_at = [&](const double* pose) {
          const double* p[] = {side == 0 ? pose : xi.data(), side == 1 ? pose : xj.data()};
          VectorXd out(6);
          EXPECT_TRUE(cost.Evaluate(p, out.data(), nullptr));
          return out;
        };
        const MatrixXd numeric_ambient =
            numeric_jacobian([&](const VectorXd& p) { return residual_at(p.data()); },
                             Eigen::Map<const VectorXd>(x.data(), 7), 1e-6);
        expect_close(J[side], numeric_ambient, 1e-6, "ambient Jacobian " + std::to_string(side));

        Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_jacobian;
        ASSERT_TRUE(manifold.PlusJacobian(x.data(), plus_jacobian.data()));
        const MatrixXd numeric_tangent = numeric_jacobian(
            [&](const VectorXd& d) {
              PoseParams y{};
              manifold.Plus(x.data(), d.data(), y.data());
              return residual_at(y.data());
            },
            VectorXd::Zero(6), 1e-6);
        expect_close(J[side] * plus_jacobian, numeric_tangent, 1e-6,
                     "Jacobian * PlusJacobian " + std::to_string(side));
      }

      // Ceres' checker compares entry by entry, so it reads numeric noise on the ~1e-8 entries of a
      // near-zero residual as failure; the norm-wise checks above cover that case.
      if (angle < 1e-3) continue;
      const std::vector<const ceres::Manifold*> manifolds = {&manifold, &manifold};
      ceres::GradientChecker checker(&cost, &manifolds, ceres::NumericDiffOptions());
      ceres::GradientChecker::ProbeResults results;
      EXPECT_TRUE(checker.Probe(params, 1e-6, &results)) << results.error_log;
    }
  }
}

}  // namespace
}  // namespace porta::slam::optim

#endif  // PORTA_OPTIM_BUILT
