// Pairing estimate poses with ground-truth poses (evaluation.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>
#include <tuple>

#include "porta/slam/evaluation.hpp"

namespace porta::slam {

namespace {

std::string format_seconds(double s) {
  char text[64];
  std::snprintf(text, sizeof text, "%.6f", s);
  return text;
}

std::string time_range(const Trajectory& t, double offset_s) {
  if (t.empty()) return "no poses";
  const auto [lo, hi] = std::minmax_element(t.poses.begin(), t.poses.end(),
                                            [](const auto& a, const auto& b) { return a.time_s < b.time_s; });
  char text[96];  // snprintf, not "[" + std::string: GCC 12 at -O3 warns falsely (-Wrestrict) on that
  std::snprintf(text, sizeof text, "[%.6f, %.6f] s", lo->time_s + offset_s, hi->time_s + offset_s);
  return text;
}

Association by_index(const Trajectory& gt, const Trajectory& est) {
  if (gt.size() != est.size()) {
    const char* which = !gt.has_times && !est.has_times ? "neither trajectory has"
                        : !gt.has_times                 ? "the ground truth has no"
                                                        : "the estimate has no";
    throw EvaluationError(std::string("cannot associate by index: ") + which +
                          " timestamps, so poses are paired by index, but the ground truth has " +
                          std::to_string(gt.size()) + " poses and the estimate " +
                          std::to_string(est.size()) +
                          "; give times for the trajectory without them (a KITTI times.txt)");
  }
  Association a;
  a.by_index = true;
  a.gt_count = gt.size();
  a.est_count = est.size();
  a.gt_index.resize(gt.size());
  std::iota(a.gt_index.begin(), a.gt_index.end(), std::size_t{0});
  a.est_index = a.gt_index;
  return a;
}

// Candidates per estimate pose: the few nearest GT times on each side within the tolerance. Enough for
// one-to-one matching of trajectories of similar rate, and bounded when the tolerance is huge.
constexpr std::size_t kCandidatesPerSide = 4;

Association by_time(const Trajectory& gt, const Trajectory& est, const AssociationOptions& options) {
  Association a;
  a.gt_count = gt.size();
  a.est_count = est.size();

  std::vector<std::size_t> gt_order(gt.size());
  std::iota(gt_order.begin(), gt_order.end(), std::size_t{0});
  std::stable_sort(gt_order.begin(), gt_order.end(),
                   [&](std::size_t l, std::size_t r) { return gt.poses[l].time_s < gt.poses[r].time_s; });
  std::vector<double> gt_times(gt.size());
  for (std::size_t k = 0; k < gt_order.size(); ++k) gt_times[k] = gt.poses[gt_order[k]].time_s;

  struct Candidate {
    double abs_dt;
    std::size_t est, gt;
  };
  std::vector<Candidate> candidates;
  for (std::size_t e = 0; e < est.size(); ++e) {
    const double t = est.poses[e].time_s + options.time_offset_s;
    const auto split =
        static_cast<std::size_t>(std::lower_bound(gt_times.begin(), gt_times.end(), t) - gt_times.begin());
    for (std::size_t k = split, n = 0; k < gt_times.size() && n < kCandidatesPerSide; ++k, ++n) {
      const double dt = std::abs(gt_times[k] - t);
      if (dt > options.max_time_diff_s) break;
      candidates.push_back({dt, e, gt_order[k]});
    }
    for (std::size_t k = split, n = 0; k > 0 && n < kCandidatesPerSide; --k, ++n) {
      const double dt = std::abs(gt_times[k - 1] - t);
      if (dt > options.max_time_diff_s) break;
      candidates.push_back({dt, e, gt_order[k - 1]});
    }
  }
  // Closest pairs first; ties in a fixed order so that the result never depends on the sort.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& l, const Candidate& r) {
    return std::tie(l.abs_dt, l.est, l.gt) < std::tie(r.abs_dt, r.est, r.gt);
  });
  std::vector<bool> est_used(est.size(), false), gt_used(gt.size(), false);
  std::vector<std::pair<std::size_t, std::size_t>> pairs;  // (est, gt)
  for (const Candidate& c : candidates) {
    if (est_used[c.est] || gt_used[c.gt]) continue;
    est_used[c.est] = gt_used[c.gt] = true;
    pairs.emplace_back(c.est, c.gt);
    a.max_abs_time_diff_s = std::max(a.max_abs_time_diff_s, c.abs_dt);
  }
  std::sort(pairs.begin(), pairs.end());
  for (const auto& [e, g] : pairs) {
    a.est_index.push_back(e);
    a.gt_index.push_back(g);
  }
  return a;
}

}  // namespace

Association associate(const Trajectory& ground_truth, const Trajectory& estimate,
                      const AssociationOptions& options) {
  if (ground_truth.empty()) throw EvaluationError("the ground truth has no poses");
  if (estimate.empty()) throw EvaluationError("the estimate has no poses");
  if (!(options.max_time_diff_s >= 0.0) || !std::isfinite(options.max_time_diff_s))
    throw EvaluationError("the maximum time difference must be a finite number >= 0, got " +
                          std::to_string(options.max_time_diff_s));
  if (!std::isfinite(options.time_offset_s)) throw EvaluationError("the time offset must be finite");

  const bool index_mode = !ground_truth.has_times || !estimate.has_times;
  Association a = index_mode ? by_index(ground_truth, estimate) : by_time(ground_truth, estimate, options);
  if (a.matched() < kMinimumPairs) {
    std::string message = "only " + std::to_string(a.matched()) + " of the estimate's " +
                          std::to_string(estimate.size()) +
                          " poses could be paired with ground truth (at least " +
                          std::to_string(kMinimumPairs) + " are needed)";
    if (!index_mode)
      message += ": ground-truth times " + time_range(ground_truth, 0.0) + ", estimate times" +
                 (options.time_offset_s != 0.0 ? " + offset " : " ") +
                 time_range(estimate, options.time_offset_s) + ", max time difference " +
                 format_seconds(options.max_time_diff_s) +
                 " s; are both in the same clock and unit (a time offset, or a larger tolerance)?";
    throw EvaluationError(message);
  }
  return a;
}

}  // namespace porta::slam
