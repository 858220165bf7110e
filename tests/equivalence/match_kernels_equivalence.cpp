// Equivalence of the middle-end kernels (DESIGN.md §3.9, §3.10): stereo_match on real and
// synthetic stereo pairs with the cpu's keypoints and descriptors of both views, and
// projection_match with queries built from real keypoints (moved, with flipped descriptor bits,
// windows of many radii, level ranges, and windows that hold nothing).
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <iostream>

#include "equivalence/compare.hpp"
#include "equivalence/harness.hpp"
#include "equivalence/inputs.hpp"

namespace porta::eq {
namespace {

/// The same pyramid in another layout of the same level sizes (left and right images may differ in pitch).
std::vector<std::uint8_t> relayout(const std::vector<std::uint8_t>& bytes, const PyramidLayout& from,
                                   const PyramidLayout& to) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(to.total_bytes), 0);
  for (std::size_t n = 0; n < to.levels.size(); ++n) {
    const Plane &a = from.levels[n], &b = to.levels[n];
    for (int y = 0; y < b.height; ++y)
      std::memcpy(out.data() + b.offset_bytes + static_cast<std::int64_t>(y) * b.pitch,
                  bytes.data() + a.offset_bytes + static_cast<std::int64_t>(y) * a.pitch,
                  static_cast<std::size_t>(b.width));
  }
  return out;
}

// ---- stereo_match --------------------------------------------------------------------------------

class StereoMatchKernel : public KernelEquivalence {};

TEST_P(StereoMatchKernel, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(left, GetParam().inputs[0], GetParam().profile);
  PORTA_EQ_SCENE_OR_SKIP(right, GetParam().inputs[1], GetParam().profile);
  ASSERT_EQ(left->layout.levels[0].width, right->layout.levels[0].width) << "a stereo pair of unequal sizes";
  ASSERT_EQ(left->layout.levels[0].height, right->layout.levels[0].height)
      << "a stereo pair of unequal sizes";
  const std::vector<std::uint8_t> right_pyramid = relayout(right->pyramid, right->layout, left->layout);
  const FrontendSettings& st = left->settings();
  const StereoParams params{left->tables.scales_q16, left->tables.stereo_row_radius_q8,
                            st.stereo_min_disparity * 256, st.stereo_max_disparity * 256,
                            st.stereo_max_hamming};
  const std::size_t n = left->oriented.size();
  const int variant = GetParam().variant;
  auto out = run_both([&](Backend& b) {
    auto lp = upload_vector(b, left->pyramid);
    auto rp = upload_vector(b, right_pyramid);
    DeviceKeypoints lk = upload_keypoints(b, left->oriented, variant);
    DeviceKeypoints rk = upload_keypoints(b, right->oriented, variant + 1);  // the other count layout
    auto ld = upload_vector(b, left->descriptors, static_cast<std::size_t>(lk.list.capacity));
    auto rd = upload_vector(b, right->descriptors, static_cast<std::size_t>(rk.list.capacity));
    auto matches = poisoned(b, std::max<std::size_t>(n, 1) * sizeof(StereoMatch));
    b.stereo_match(*lp, *rp, left->layout, lk.list, *ld, rk.list, *rd, params, *matches);
    return download_vector<StereoMatch>(b, *matches, n);
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size() * sizeof(StereoMatch), n / 2 * sizeof(StereoMatch));
  expect_same(compare_stereo_matches(out->first, out->second, {"cpu", backend_name()}, [&](std::size_t i) {
    return "match of left " + locate_keypoint(left->oriented, i);
  }));
  if (const char* v = std::getenv("PORTA_EQUIVALENCE_VERBOSE"); v != nullptr && *v != '\0' && *v != '0') {
    int matched = 0;
    for (const StereoMatch& m : out->first) matched += m.disparity_q8 >= 0 ? 1 : 0;
    std::cout << "[ stereo   ] " << matched << " of " << n << " left keypoints matched by cpu\n";
  }
}

INSTANTIATE_TEST_SUITE_P(Equivalence, StereoMatchKernel, ::testing::ValuesIn(cases_for("stereo_match")),
                         case_name);

// ---- projection_match ----------------------------------------------------------------------------

std::uint64_t next_random(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
int random_below(std::uint64_t& state, int n) {
  return static_cast<int>(next_random(state) % static_cast<std::uint64_t>(n));
}

std::int32_t pos_q8(int c, std::int32_t scale_q16) {
  return static_cast<std::int32_t>((static_cast<std::int64_t>(c) * scale_q16 + 128) >> 8);
}

struct Queries {
  std::vector<ProjectionQuery> queries;
  std::vector<Descriptor> descriptors;
};

/// Queries in eight kinds, cycling: at a keypoint exactly (radius 0), moved by up to 3 px with
/// radii 1, 4, 16 and 64 px, an empty level range, a window off the image, and a random place.
Queries make_queries(const Scene& s, std::uint64_t seed) {
  Queries q;
  const auto& kps = s.oriented;
  const int levels = s.settings().levels;
  const Plane& l0 = s.layout.levels[0];
  const int n = static_cast<int>(std::min<std::size_t>(3000, 4 * kps.size() + 40));
  std::uint64_t state = seed * 7919 + 1;
  auto random_descriptor = [&] {
    Descriptor d;
    for (auto& b : d.bytes) b = static_cast<std::uint8_t>(next_random(state));
    return d;
  };
  for (int i = 0; i < n; ++i) {
    int kind = i % 8;
    if (kps.empty() && kind < 6) kind = 6 + i % 2;
    ProjectionQuery query;
    Descriptor d;
    if (kind < 6) {
      const auto k = static_cast<std::size_t>(random_below(state, static_cast<int>(kps.size())));
      const Keypoint& kp = kps[k];
      const std::int32_t scale = s.tables.scales_q16[kp.level];
      const int noise = kind == 0 ? 0 : 3 * 256;
      query.u_q8 = pos_q8(kp.x, scale) + (noise ? random_below(state, 2 * noise + 1) - noise : 0);
      query.v_q8 = pos_q8(kp.y, scale) + (noise ? random_below(state, 2 * noise + 1) - noise : 0);
      static const std::int32_t radius_px_q8[] = {0, 256, 4 * 256, 16 * 256, 64 * 256, 3 * 256};
      query.radius_q8 = radius_px_q8[kind];
      switch (i % 3) {
        case 0:  // every level
          query.min_level = 0;
          query.max_level = static_cast<std::uint8_t>(levels - 1);
          break;
        case 1:  // the predicted level +-1
          query.min_level = static_cast<std::uint8_t>(std::max(0, kp.level - 1));
          query.max_level = static_cast<std::uint8_t>(std::min(levels - 1, kp.level + 1));
          break;
        default:  // the predicted level only
          query.min_level = query.max_level = kp.level;
      }
      if (kind == 5) {  // an empty level range
        query.min_level = static_cast<std::uint8_t>(kp.level + 1);
        query.max_level = kp.level;
      }
      d = s.descriptors[k];
      const int flips = kind == 3 ? 0 : random_below(state, 48);
      for (int f = 0; f < flips; ++f) {
        const int bit = random_below(state, 256);
        d.bytes[static_cast<std::size_t>(bit / 8)] ^= static_cast<std::uint8_t>(1u << (bit % 8));
      }
    } else if (kind == 6) {  // far off the image: nothing in the window
      query.u_q8 = -100000 * 256;
      query.v_q8 = (l0.height + 5000) * 256;
      query.radius_q8 = 256;
      query.max_level = static_cast<std::uint8_t>(levels - 1);
      d = random_descriptor();
    } else {  // anywhere, medium window, random descriptor
      query.u_q8 = random_below(state, l0.width * 256);
      query.v_q8 = random_below(state, l0.height * 256);
      query.radius_q8 = 8 * 256;
      query.max_level = static_cast<std::uint8_t>(levels - 1);
      d = random_descriptor();
    }
    q.queries.push_back(query);
    q.descriptors.push_back(d);
  }
  return q;
}

class ProjectionMatchKernel : public KernelEquivalence {};

TEST_P(ProjectionMatchKernel, MatchesCpu) {
  PORTA_EQ_SCENE_OR_SKIP(s, GetParam().inputs[0], GetParam().profile);
  const Queries q = make_queries(*s, static_cast<std::uint64_t>(GetParam().variant) + 1);
  const auto n = static_cast<int>(q.queries.size());
  auto out = run_both([&](Backend& b) {
    DeviceKeypoints kps = upload_keypoints(b, s->oriented, GetParam().variant);
    auto kp_descriptors = upload_vector(b, s->descriptors, static_cast<std::size_t>(kps.list.capacity));
    auto queries = upload_vector(b, q.queries);
    auto query_descriptors = upload_vector(b, q.descriptors);
    auto results = poisoned(b, static_cast<std::size_t>(n) * sizeof(ProjectionResult));
    b.projection_match(kps.list, *kp_descriptors, *queries, *query_descriptors, n, s->tables.scales_q16,
                       *results);
    return download_vector<ProjectionResult>(b, *results, static_cast<std::size_t>(n));
  });
  if (!out) return;
  debug_corrupt(out->second.data(), out->second.size() * sizeof(ProjectionResult),
                out->second.size() / 2 * sizeof(ProjectionResult));
  expect_same(
      compare_projection_results(out->first, out->second, {"cpu", backend_name()}, [&](std::size_t i) {
        const ProjectionQuery& p = q.queries[i];
        return "query " + std::to_string(i) + " (u_q8 " + std::to_string(p.u_q8) + ", v_q8 " +
               std::to_string(p.v_q8) + ", radius_q8 " + std::to_string(p.radius_q8) + ", levels [" +
               std::to_string(p.min_level) + ", " + std::to_string(p.max_level) + "])";
      }));
}

INSTANTIATE_TEST_SUITE_P(Equivalence, ProjectionMatchKernel,
                         ::testing::ValuesIn(cases_for("projection_match")), case_name);

}  // namespace
}  // namespace porta::eq
