// RANSAC around EPnP for relocalisation (after ORB-SLAM2's PnPsolver); see pnp.hpp.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "porta/slam/optim/pnp.hpp"
#include "porta/slam/optim/ransac_random.hpp"

namespace porta::slam::optim {
namespace {

// Marks the inliers of T_cw (positive depth, squared pixel error < chi2 * sigma2); returns their number.
int classify(const StereoCamera& camera, std::span<const Eigen::Vector3d> points_world,
             std::span<const Eigen::Vector2d> uv, std::span<const double> sigma2, const SE3& T_cw,
             double chi2, std::vector<bool>& inlier) {
  int count = 0;
  for (std::size_t i = 0; i < points_world.size(); ++i) {
    const Eigen::Vector3d p = T_cw * points_world[i];
    bool ok = p.z() > 0.0;  // a point behind the camera projects onto a valid-looking pixel
    if (ok) {
      const double du = camera.fx * p.x() / p.z() + camera.cx - uv[i].x();
      const double dv = camera.fy * p.y() / p.z() + camera.cy - uv[i].y();
      ok = du * du + dv * dv < chi2 * sigma2[i];
    }
    inlier[i] = ok;
    count += ok ? 1 : 0;
  }
  return count;
}

void validate(const PnpRansacOptions& o, std::size_t num_points, std::size_t num_uv,
              std::span<const double> sigma2) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("solve_pnp_ransac: " + what); };
  if (!(o.probability > 0.0 && o.probability < 1.0))
    fail("options.probability is " + std::to_string(o.probability) + ", must be in (0, 1)");
  if (o.min_inliers < 4) fail("options.min_inliers is " + std::to_string(o.min_inliers) + ", must be >= 4");
  if (o.max_iterations < 1)
    fail("options.max_iterations is " + std::to_string(o.max_iterations) + ", must be >= 1");
  if (o.min_set < 4) fail("options.min_set is " + std::to_string(o.min_set) + ", must be >= 4 (EPnP)");
  if (!(o.chi2 > 0.0) || !std::isfinite(o.chi2))
    fail("options.chi2 is " + std::to_string(o.chi2) + ", must be > 0 and finite");
  if (num_uv != num_points || sigma2.size() != num_points)
    fail("points_world, uv and sigma2 have sizes " + std::to_string(num_points) + ", " +
         std::to_string(num_uv) + " and " + std::to_string(sigma2.size()) + ", must be equal");
  for (std::size_t i = 0; i < sigma2.size(); ++i)
    if (!(sigma2[i] > 0.0))
      fail("sigma2[" + std::to_string(i) + "] is " + std::to_string(sigma2[i]) + ", must be > 0");
}

}  // namespace

PnpRansacResult solve_pnp_ransac(const StereoCamera& camera, std::span<const Eigen::Vector3d> points_world,
                                 std::span<const Eigen::Vector2d> uv, std::span<const double> sigma2,
                                 const PnpRansacOptions& options) {
  camera.validate();
  validate(options, points_world.size(), uv.size(), sigma2);
  const std::size_t n = points_world.size();
  PnpRansacResult result;
  result.inlier.assign(n, false);
  if (n < static_cast<std::size_t>(std::max(options.min_set, options.min_inliers))) return result;

  SplitMix64 rng(options.seed);
  std::vector<std::size_t> sample(static_cast<std::size_t>(options.min_set));
  std::vector<Eigen::Vector3d> sample_world(sample.size());
  std::vector<Eigen::Vector2d> sample_uv(sample.size());
  std::vector<bool> inlier(n, false);
  int best_inliers = -1;
  SE3 best_T = SE3::Identity();
  int needed_iterations = options.max_iterations;
  while (result.iterations < needed_iterations) {
    ++result.iterations;
    sample_distinct_indices(rng, n, sample);
    for (std::size_t k = 0; k < sample.size(); ++k) {
      sample_world[k] = points_world[sample[k]];
      sample_uv[k] = uv[sample[k]];
    }
    const std::optional<SE3> T_cw = solve_epnp(sample_world, sample_uv, camera);
    if (!T_cw) continue;
    const int count = classify(camera, points_world, uv, sigma2, *T_cw, options.chi2, inlier);
    if (count > best_inliers) {  // strictly more: ties keep the first found
      best_inliers = count;
      best_T = *T_cw;
      result.inlier = inlier;
      needed_iterations =
          ransac_required_iterations(options.probability, static_cast<double>(count) / static_cast<double>(n),
                                     options.min_set, options.max_iterations);
    }
  }
  if (best_inliers <= 0) {  // every sample degenerate, or no hypothesis explains anything
    result.inlier.assign(n, false);
    return result;
  }

  // Refine on all inliers of the winner (the minimal sample's pose carries its points' noise);
  // solve_epnp declines fewer than 4.
  std::vector<Eigen::Vector3d> inlier_world;
  std::vector<Eigen::Vector2d> inlier_uv;
  for (std::size_t i = 0; i < n; ++i) {
    if (!result.inlier[i]) continue;
    inlier_world.push_back(points_world[i]);
    inlier_uv.push_back(uv[i]);
  }
  if (const std::optional<SE3> refined = solve_epnp(inlier_world, inlier_uv, camera)) {
    const int count = classify(camera, points_world, uv, sigma2, *refined, options.chi2, inlier);
    if (count >= best_inliers) {
      best_inliers = count;
      best_T = *refined;
      result.inlier = inlier;
    }
  }
  result.T_cw = best_T;
  result.num_inliers = best_inliers;
  result.found = best_inliers >= options.min_inliers;
  return result;
}

}  // namespace porta::slam::optim
