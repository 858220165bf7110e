// porta_ba_bench: local bundle adjustment, our Schur solver against Ceres' DENSE_SCHUR on the same
// window (docs/BENCHMARKS.md, "Local bundle adjustment"), and tracking's pose-only optimisation.
// Google Benchmark; one iteration is one whole local_bundle_adjustment() call (both stages, the
// outlier test) from the same start, or one optimize_pose() call (its four rounds).
//
// The window has the shape local mapping gives it on the rendered KITTI 00 drive: 30 free and 30
// fixed keyframes a metre apart, each point seen by the 5 keyframes after the one that made it,
// about 5 000 points and 25 000 observations, 60 % of them stereo; 1 px noise, 2 % gross outliers,
// free poses ~2 cm / 0.1 deg and points ~5 cm off. SchurThreads/N: ours with its loops on a pool of N
// threads kept across calls, as local mapping keeps one (same result as on one thread).
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <numbers>
#include <random>
#include <vector>

#include "cpu/thread_pool.hpp"
#include "porta/slam/optim/local_bundle_adjustment.hpp"
#include "porta/slam/optim/pose_optimization.hpp"

namespace {

using porta::slam::SE3;
using porta::slam::StereoCamera;
using namespace porta::slam::optim;

constexpr int kFixedKeyframes = 30;
constexpr int kFreeKeyframes = 30;
constexpr int kPoints = 5000;
constexpr int kObserversPerPoint = 5;

StereoCamera kitti_camera() { return StereoCamera{1242, 375, 718.856, 718.856, 607.193, 185.216, 0.537}; }

struct Window {
  std::vector<BaKeyframe> keyframes;
  std::vector<Eigen::Vector3d> points;
  std::vector<BaObservation> observations;
};

Window make_window(unsigned seed) {
  const StereoCamera camera = kitti_camera();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const int n = kFixedKeyframes + kFreeKeyframes;
  std::vector<SE3> truth;
  for (int k = 0; k < n; ++k) {  // forward along z, turning slowly about y
    SE3 T_wc = SE3::Identity();
    T_wc.linear() = Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d::UnitY()).toRotationMatrix();
    T_wc.translation() = Eigen::Vector3d(0.05 * k, 0.0, 1.0 * k);
    truth.push_back(T_wc.inverse());
  }
  Window w;
  for (int k = 0; k < n; ++k) {
    SE3 T = truth[static_cast<std::size_t>(k)];
    const bool fixed = k < kFixedKeyframes;
    if (!fixed) {
      SE3 delta = SE3::Identity();
      delta.linear() = Eigen::AngleAxisd(0.1 * std::numbers::pi / 180.0,
                                         Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized())
                           .toRotationMatrix();
      delta.translation() = 0.02 * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
      T = delta * T;
    }
    w.keyframes.push_back({T, fixed});
  }
  while (w.points.size() < static_cast<std::size_t>(kPoints)) {
    // Made by keyframe `birth`, in its view at 3-25 m; seen by it and the next ones while in view.
    const int birth = static_cast<int>(uniform(rng) * (n - 1));
    const double depth = 3.0 + 22.0 * uniform(rng);
    const double u = camera.width * uniform(rng), v = camera.height * uniform(rng);
    const Eigen::Vector3d p_c((u - camera.cx) / camera.fx * depth, (v - camera.cy) / camera.fy * depth, depth);
    const Eigen::Vector3d X = truth[static_cast<std::size_t>(birth)].inverse() * p_c;
    const std::size_t index = w.points.size();
    int seen = 0;
    for (int k = birth; k < n && seen < kObserversPerPoint; ++k) {
      const Eigen::Vector3d p = truth[static_cast<std::size_t>(k)] * X;
      if (p.z() < 1.0) break;
      const double uk = camera.fx * p.x() / p.z() + camera.cx, vk = camera.fy * p.y() / p.z() + camera.cy;
      if (uk < 0.0 || uk >= camera.width || vk < 0.0 || vk >= camera.height) break;
      BaObservation o;
      o.keyframe = static_cast<std::size_t>(k);
      o.point = index;
      const int level = static_cast<int>(uniform(rng) * 4.0);
      const double sigma = std::pow(1.2, level);
      o.sigma2 = sigma * sigma;
      o.u_left = uk + sigma * gauss(rng);
      o.v = vk + sigma * gauss(rng);
      if (uniform(rng) < 0.6) o.u_right = uk - camera.bf() / p.z() + sigma * gauss(rng);
      if (uniform(rng) < 0.02) o.u_left += 30.0 + 30.0 * uniform(rng);
      w.observations.push_back(o);
      ++seen;
    }
    if (seen < 2) {  // a point seen once is not a bundle adjustment point
      w.observations.resize(w.observations.size() - static_cast<std::size_t>(seen));
      continue;
    }
    w.points.push_back(X + 0.05 * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)));
  }
  return w;
}

void run(benchmark::State& state, BaSolver solver, int threads = 0) {
  const Window w = make_window(7);
  LocalBundleAdjustmentOptions options;
  options.solver = solver;
  porta::cpu::ThreadPool pool(std::max(threads, 1));
  if (threads > 0) {  // 1: the split loops, run on the calling thread
    options.parallel_for = [&pool](std::int64_t n, const std::function<void(std::int64_t)>& fn) {
      pool.parallel_for(0, n, fn);
    };
  }
  LocalBundleAdjustmentResult result;
  for (auto _ : state) {
    result = local_bundle_adjustment(kitti_camera(), w.keyframes, w.points, w.observations, options);
    benchmark::DoNotOptimize(result.final_cost);
  }
  state.counters["keyframes"] = static_cast<double>(w.keyframes.size());
  state.counters["points"] = static_cast<double>(w.points.size());
  state.counters["observations"] = static_cast<double>(w.observations.size());
  state.counters["iterations"] = result.iterations;
  state.counters["final_cost"] = result.final_cost;
  state.counters["rmse_px"] = result.final_rmse_px;
}

void BM_LocalBundleAdjustment_Schur(benchmark::State& state) { run(state, BaSolver::schur); }
void BM_LocalBundleAdjustment_SchurThreads(benchmark::State& state) {
  run(state, BaSolver::schur, static_cast<int>(state.range(0)));
}
void BM_LocalBundleAdjustment_CeresDenseSchur(benchmark::State& state) { run(state, BaSolver::ceres_dense_schur); }

// Tracking's pose-only optimisation on one frame as the local-map search leaves it on the rendered
// KITTI drive: 700 matched points 3-40 m ahead, 70 % with stereo, levels 0-7 (sigma 1.2^level,
// 1 sigma of noise), 8 % gross outliers; the start 5 cm and 0.2 deg off (the motion model's guess).
// /0: each round from the round before's pose; /1: each from the start (ORB-SLAM2, the default).
void BM_PoseOptimization(benchmark::State& state) {
  const StereoCamera camera = kitti_camera();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  SE3 truth = SE3::Identity();
  truth.translation() = Eigen::Vector3d(0.1, -0.05, -3.0);
  std::vector<PoseObservation> observations;
  while (observations.size() < 700) {
    const double depth = 3.0 + 37.0 * uniform(rng);
    const double u = camera.width * uniform(rng), v = camera.height * uniform(rng);
    const Eigen::Vector3d p_c((u - camera.cx) / camera.fx * depth, (v - camera.cy) / camera.fy * depth, depth);
    PoseObservation o;
    o.point_world = truth.inverse() * p_c;
    const int level = static_cast<int>(uniform(rng) * 8.0);
    const double sigma = std::pow(1.2, level);
    o.sigma2 = sigma * sigma;
    o.u_left = u + sigma * gauss(rng);
    o.v = v + sigma * gauss(rng);
    if (uniform(rng) < 0.7) o.u_right = u - camera.bf() / depth + sigma * gauss(rng);
    if (uniform(rng) < 0.08) o.u_left += 30.0 + 30.0 * uniform(rng);
    observations.push_back(o);
  }
  SE3 start = truth;
  start.linear() = Eigen::AngleAxisd(0.2 * std::numbers::pi / 180.0, Eigen::Vector3d(0.3, 1.0, 0.2).normalized())
                       .toRotationMatrix() * truth.linear();
  start.translation() += Eigen::Vector3d(0.03, -0.02, 0.035);
  PoseOptimizationOptions options;
  options.restart_each_round = state.range(0) != 0;  // /1: every round from the start (ORB-SLAM2)
  PoseOptimizationResult result;
  for (auto _ : state) {
    result = optimize_pose(camera, start, observations, options);
    benchmark::DoNotOptimize(result.T_cw);
  }
  state.counters["observations"] = static_cast<double>(observations.size());
  state.counters["inliers"] = result.num_inliers;
  state.counters["rounds_solved"] = result.rounds_solved;
  state.counters["passes"] = result.passes;
  state.counters["error_mm"] = 1000.0 * (result.T_cw.translation() - truth.translation()).norm();
}

BENCHMARK(BM_LocalBundleAdjustment_Schur)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LocalBundleAdjustment_SchurThreads)->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_LocalBundleAdjustment_CeresDenseSchur)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PoseOptimization)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
