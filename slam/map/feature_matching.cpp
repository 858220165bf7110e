// Shared keyframe-to-keyframe matching pieces (feature_matching.hpp).
#include "porta/slam/feature_matching.hpp"

#include <array>
#include <cmath>
#include <cstdint>

#include "descriptor_scan.hpp"
#include "porta/slam/map.hpp"

namespace porta::slam {
namespace {
constexpr int kRotationBins = 30;
}

void keep_consistent_rotations(std::vector<FeatureMatch>& matches, const FrameFeatures& f1,
                               const FrameFeatures& f2) {
  std::array<int, kRotationBins> counts{};
  std::vector<int> bins(matches.size());
  constexpr double kTwoPi = 6.283185307179586;
  for (std::size_t m = 0; m < matches.size(); ++m) {
    double change = static_cast<double>(f1.angle_rad[static_cast<std::size_t>(matches[m].feature1)]) -
                    static_cast<double>(f2.angle_rad[static_cast<std::size_t>(matches[m].feature2)]);
    change = std::fmod(change, kTwoPi);
    if (change < 0.0) change += kTwoPi;
    bins[m] = static_cast<int>(std::lround(change / kTwoPi * kRotationBins)) % kRotationBins;
    ++counts[static_cast<std::size_t>(bins[m])];
  }
  std::array<int, 3> top{-1, -1, -1};  // bin indices, most populated first (ties: smaller bin)
  for (int b = 0; b < kRotationBins; ++b) {
    const int c = counts[static_cast<std::size_t>(b)];
    if (c == 0) continue;
    for (std::size_t k = 0; k < top.size(); ++k) {
      if (top[k] < 0 || c > counts[static_cast<std::size_t>(top[k])]) {
        for (std::size_t j = top.size() - 1; j > k; --j) top[j] = top[j - 1];
        top[k] = b;
        break;
      }
    }
  }
  if (top[0] < 0) return;
  const double max_count = counts[static_cast<std::size_t>(top[0])];
  if (top[1] >= 0 && counts[static_cast<std::size_t>(top[1])] < 0.1 * max_count) top[1] = top[2] = -1;
  if (top[2] >= 0 && counts[static_cast<std::size_t>(top[2])] < 0.1 * max_count) top[2] = -1;
  std::vector<FeatureMatch> kept;
  for (std::size_t m = 0; m < matches.size(); ++m) {
    if (bins[m] == top[0] || bins[m] == top[1] || bins[m] == top[2]) kept.push_back(matches[m]);
  }
  matches = std::move(kept);
}

std::vector<FeatureMatch> match_by_descriptor(const FrameFeatures& a, const std::vector<int>& from_a,
                                              const FrameFeatures& b, const std::vector<int>& from_b,
                                              int max_distance, double ratio) {
  std::vector<int> owner(b.size(), -1);  // b feature -> index into `found`
  std::vector<FeatureMatch> found;
  const detail::DescriptorPlanes candidates(b.descriptors, from_b);
  std::vector<std::uint16_t> distances;
  for (const int i : from_a) {
    const detail::Nearest nearest = candidates.nearest(a.descriptors[static_cast<std::size_t>(i)], distances);
    if (nearest.index < 0 || nearest.best > max_distance || nearest.best >= ratio * nearest.second) continue;
    const int best_j = from_b[static_cast<std::size_t>(nearest.index)];
    int& o = owner[static_cast<std::size_t>(best_j)];
    if (o >= 0) {
      if (found[static_cast<std::size_t>(o)].distance <= nearest.best) continue;
      found[static_cast<std::size_t>(o)].feature1 = -1;  // displaced by a closer one
    }
    o = static_cast<int>(found.size());
    found.push_back({i, best_j, nearest.best});
  }
  std::vector<FeatureMatch> matches;
  for (const FeatureMatch& m : found) {
    if (m.feature1 >= 0) matches.push_back(m);
  }
  keep_consistent_rotations(matches, a, b);
  return matches;
}

}  // namespace porta::slam
