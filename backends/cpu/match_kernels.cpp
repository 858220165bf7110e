// Stereo matching and projection matching (DESIGN.md §3.9, §3.10): the reference definitions.
// Candidate searches run over keypoints sorted by level-0 row, with explicit index tie-breaks,
// so the result is the one a full scan in index order gives, whatever the thread count.
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "cpu/stereo_math.hpp"
#include "porta/kernel_checks.hpp"

namespace porta::cpu {

namespace {

using stereo::kSadHalfWindow;
using stereo::kSadSearch;

/// A keypoint's level-0 position, for searches over keypoints sorted by row.
struct PlacedKeypoint {
  std::int32_t v_q8 = 0;
  std::int32_t u_q8 = 0;
  std::int32_t index = 0;
  std::int32_t level = 0;
};

bool row_then_index(const PlacedKeypoint& a, const PlacedKeypoint& b) {
  return a.v_q8 != b.v_q8 ? a.v_q8 < b.v_q8 : a.index < b.index;
}

/// The entries of `sorted` (by row) whose row lies in [v_lo, v_hi].
template <typename Fn>
void for_rows_in(const std::vector<PlacedKeypoint>& sorted, std::int64_t v_lo, std::int64_t v_hi, Fn&& fn) {
  auto it = std::lower_bound(sorted.begin(), sorted.end(), v_lo,
                             [](const PlacedKeypoint& p, std::int64_t v) { return p.v_q8 < v; });
  for (; it != sorted.end() && it->v_q8 <= v_hi; ++it) fn(*it);
}

std::int64_t abs64(std::int64_t v) { return v < 0 ? -v : v; }

/// Sum over the 11 x 11 window of |(L(p) - L(centre)) - (R(p + shift) - R(centre + shift))|:
/// ORB-SLAM2 normalises both windows by their centre pixel before comparing them.
std::int32_t centred_sad(const std::uint8_t* left, const std::uint8_t* right, int pitch, int x_left, int x_right,
                         int y) {
  const int left_centre = left[static_cast<std::int64_t>(y) * pitch + x_left];
  const int right_centre = right[static_cast<std::int64_t>(y) * pitch + x_right];
  std::int32_t sad = 0;
  for (int dy = -kSadHalfWindow; dy <= kSadHalfWindow; ++dy) {
    const std::uint8_t* lrow = left + static_cast<std::int64_t>(y + dy) * pitch;
    const std::uint8_t* rrow = right + static_cast<std::int64_t>(y + dy) * pitch;
    for (int dx = -kSadHalfWindow; dx <= kSadHalfWindow; ++dx) {
      const int diff = (lrow[x_left + dx] - left_centre) - (rrow[x_right + dx] - right_centre);
      sad += diff < 0 ? -diff : diff;
    }
  }
  return sad;
}

/// Everything stereo_match needs for one left keypoint, read-only and shared by all threads.
struct StereoInputs {
  const Keypoint* left = nullptr;
  const Keypoint* right = nullptr;
  const Descriptor* left_descriptors = nullptr;
  const Descriptor* right_descriptors = nullptr;
  const std::uint8_t* left_pyramid = nullptr;
  const std::uint8_t* right_pyramid = nullptr;
  const PyramidLayout* layout = nullptr;
  const StereoParams* params = nullptr;
  std::vector<std::vector<PlacedKeypoint>> right_by_level;  // each sorted by (row, index)
};

/// Steps a-e of the contract for left keypoint i; returns false for "no match".
bool match_left_keypoint(const StereoInputs& in, int i, StereoMatch& match, std::int32_t& sad_out) {
  const StereoParams& p = *in.params;
  const Keypoint& kl = in.left[i];
  const int levels = in.layout->num_levels();
  const int nl = kl.level;
  if (nl >= levels) return false;
  const std::int32_t ul = stereo::level0_q8(kl.x, p.scales_q16[static_cast<std::size_t>(nl)]);
  const std::int32_t vl = stereo::level0_q8(kl.y, p.scales_q16[static_cast<std::size_t>(nl)]);

  // a, b: the right keypoint of smallest Hamming distance among the candidates, ties to lower j.
  int best_j = -1;
  int best_distance = 256;
  const Descriptor& dl = in.left_descriptors[i];
  for (int nr = std::max(0, nl - 1); nr <= std::min(levels - 1, nl + 1); ++nr) {
    const std::int32_t radius = p.row_radius_q8[static_cast<std::size_t>(nr)];
    for_rows_in(in.right_by_level[static_cast<std::size_t>(nr)], static_cast<std::int64_t>(vl) - radius,
                static_cast<std::int64_t>(vl) + radius, [&](const PlacedKeypoint& r) {
                  const std::int64_t disparity = static_cast<std::int64_t>(ul) - r.u_q8;
                  if (disparity < p.min_disparity_q8 || disparity > p.max_disparity_q8) return;
                  const int distance = stereo::hamming_distance(dl, in.right_descriptors[r.index]);
                  if (best_j < 0 || distance < best_distance || (distance == best_distance && r.index < best_j)) {
                    best_distance = distance;
                    best_j = r.index;
                  }
                });
  }
  if (best_j < 0 || best_distance >= p.max_hamming) return false;

  // c: SAD search at the left level around the right keypoint's column taken to that level.
  const Plane& plane = in.layout->levels[static_cast<std::size_t>(nl)];
  const Keypoint& kr = in.right[best_j];
  const std::int64_t ratio =
      stereo::level_ratio_q16(p.scales_q16[kr.level], p.scales_q16[static_cast<std::size_t>(nl)]);
  const std::int64_t xr = kr.level == nl ? kr.x : stereo::scale_column(kr.x, ratio);
  constexpr int kReach = kSadHalfWindow + kSadSearch;
  if (xr - kReach < 0 || xr + kReach >= plane.width) return false;
  // The left window must lie inside the level too (always so for keypoints found with edge >= 19).
  if (kl.x < kSadHalfWindow || kl.x + kSadHalfWindow >= plane.width || kl.y < kSadHalfWindow ||
      kl.y + kSadHalfWindow >= plane.height)
    return false;

  const std::uint8_t* left_level = in.left_pyramid + plane.offset_bytes;
  const std::uint8_t* right_level = in.right_pyramid + plane.offset_bytes;
  std::int32_t sads[2 * kSadSearch + 1];
  int best_slot = 0;
  for (int slot = 0; slot <= 2 * kSadSearch; ++slot) {
    const int inc = slot - kSadSearch;
    sads[slot] = centred_sad(left_level, right_level, plane.pitch, kl.x, static_cast<int>(xr) + inc, kl.y);
    if (sads[slot] < sads[best_slot]) best_slot = slot;  // strict: ties keep the smaller increment
  }
  if (best_slot == 0 || best_slot == 2 * kSadSearch) return false;

  // d: parabola through the best SAD and its neighbours.
  std::int32_t delta_q8 = 0;
  if (!stereo::parabola_delta_q8(sads[best_slot - 1], sads[best_slot], sads[best_slot + 1], delta_q8)) return false;

  // e: disparity at the left level, then at level 0.
  const int inc = best_slot - kSadSearch;
  const std::int64_t level_disparity_q8 = (static_cast<std::int64_t>(kl.x) - xr - inc) * 256 - delta_q8;
  if (level_disparity_q8 < 0) return false;
  const std::int32_t d0 = stereo::level0_disparity_q8(static_cast<std::int32_t>(level_disparity_q8),
                                                      p.scales_q16[static_cast<std::size_t>(nl)]);
  if (d0 < p.min_disparity_q8 || d0 > p.max_disparity_q8) return false;
  match = StereoMatch{d0, best_j};
  sad_out = sads[best_slot];
  return true;
}

}  // namespace

// §3.9: for each left keypoint the best-Hamming right keypoint within the row band, level band
// and disparity range, refined by an 11x11 centred-SAD search and a parabola; matches whose SAD
// exceeds 2.1x the median SAD of all matches are dropped. Output at matches[i], {-1, -1} = none.
void CpuBackend::stereo_match(const Buffer& left_pyramid, const Buffer& right_pyramid, const PyramidLayout& layout,
                              ConstDeviceList left_keypoints, const Buffer& left_descriptors,
                              ConstDeviceList right_keypoints, const Buffer& right_descriptors,
                              const StereoParams& params, Buffer& matches) {
  const auto levels = static_cast<std::size_t>(layout.num_levels());
  checks::check_stereo_tables("cpu", layout, params);

  StereoInputs in;
  in.left = as<Keypoint>(*left_keypoints.items);
  in.right = as<Keypoint>(*right_keypoints.items);
  in.left_descriptors = as<Descriptor>(left_descriptors);
  in.right_descriptors = as<Descriptor>(right_descriptors);
  in.left_pyramid = as<std::uint8_t>(left_pyramid);
  in.right_pyramid = as<std::uint8_t>(right_pyramid);
  in.layout = &layout;
  in.params = &params;

  const int num_left = list_count(left_keypoints);
  const int num_right = list_count(right_keypoints);
  in.right_by_level.resize(levels);
  for (int j = 0; j < num_right; ++j) {
    const Keypoint& k = in.right[j];
    if (static_cast<std::size_t>(k.level) >= levels) continue;  // not a level of this pyramid: never a candidate
    const std::int32_t s = params.scales_q16[k.level];
    in.right_by_level[k.level].push_back({stereo::level0_q8(k.y, s), stereo::level0_q8(k.x, s), j, k.level});
  }
  for (auto& level : in.right_by_level) std::sort(level.begin(), level.end(), row_then_index);

  StereoMatch* out = as<StereoMatch>(matches);
  std::vector<std::int32_t> sad(static_cast<std::size_t>(num_left), -1);
  pool().parallel_for(0, num_left, [&](std::int64_t i) {
    StereoMatch m;
    if (!match_left_keypoint(in, static_cast<int>(i), m, sad[static_cast<std::size_t>(i)])) m = StereoMatch{};
    out[i] = m;
  });

  // f: median SAD of the accepted matches, then the outlier cut (sequential, order-free).
  std::vector<std::int32_t> accepted;
  for (const std::int32_t s : sad)
    if (s >= 0) accepted.push_back(s);
  if (accepted.empty()) return;
  const std::int32_t median = stereo::median_sad(std::move(accepted));
  for (int i = 0; i < num_left; ++i)
    if (sad[static_cast<std::size_t>(i)] >= 0 && stereo::sad_is_outlier(sad[static_cast<std::size_t>(i)], median))
      out[i] = StereoMatch{};
}

// §3.10: per query, the keypoint of smallest Hamming distance (ties to the lower index) among
// those within the inclusive square window and level range, and the smallest distance among the
// other candidates; -1 / 256 / 256 when the window holds none.
void CpuBackend::projection_match(ConstDeviceList keypoints, const Buffer& keypoint_descriptors, const Buffer& queries,
                                  const Buffer& query_descriptors, int num_queries,
                                  const std::vector<std::int32_t>& scales_q16, Buffer& results) {
  const Keypoint* kps = as<Keypoint>(*keypoints.items);
  const Descriptor* kp_desc = as<Descriptor>(keypoint_descriptors);
  const ProjectionQuery* q = as<ProjectionQuery>(queries);
  const Descriptor* q_desc = as<Descriptor>(query_descriptors);
  ProjectionResult* out = as<ProjectionResult>(results);

  const int n = list_count(keypoints);
  std::vector<PlacedKeypoint> by_row;
  by_row.reserve(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    if (static_cast<std::size_t>(kps[k].level) >= scales_q16.size()) continue;  // no scale for it: never a candidate
    const std::int32_t s = scales_q16[kps[k].level];
    by_row.push_back({stereo::level0_q8(kps[k].y, s), stereo::level0_q8(kps[k].x, s), k, kps[k].level});
  }
  std::sort(by_row.begin(), by_row.end(), row_then_index);

  pool().parallel_for(0, num_queries, [&](std::int64_t i) {
    const ProjectionQuery& query = q[i];
    const Descriptor& d = q_desc[i];
    ProjectionResult r;
    for_rows_in(by_row, static_cast<std::int64_t>(query.v_q8) - query.radius_q8,
                static_cast<std::int64_t>(query.v_q8) + query.radius_q8, [&](const PlacedKeypoint& p) {
                  if (p.level < query.min_level || p.level > query.max_level) return;
                  if (abs64(static_cast<std::int64_t>(p.u_q8) - query.u_q8) > query.radius_q8) return;
                  const int distance = stereo::hamming_distance(d, kp_desc[p.index]);
                  if (r.best_index < 0 || distance < r.best_distance ||
                      (distance == r.best_distance && p.index < r.best_index)) {
                    // The displaced best (256 when there was none) is now a runner-up.
                    r.second_distance = std::min(r.second_distance, r.best_distance);
                    r.best_distance = distance;
                    r.best_index = p.index;
                  } else {
                    r.second_distance = std::min(r.second_distance, distance);
                  }
                });
    out[i] = r;
  });
}

}  // namespace porta::cpu
