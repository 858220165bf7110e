// The brute-force descriptor scan (slam/map/descriptor_scan.hpp) and match_by_descriptor on it,
// against the sequential scan they replace, on both bit-count paths: the portable loop everywhere,
// the AVX-512 VPOPCNTDQ one where the CPU has it (elsewhere both runs take the portable loop; the
// 2-core CI machine has it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "porta/slam/feature_matching.hpp"
#include "porta/slam/map.hpp"
#include "slam/map/descriptor_scan.hpp"

namespace porta::slam {
namespace {

Descriptor random_descriptor(std::mt19937_64& rng) {
  Descriptor d;
  for (std::size_t w = 0; w < 4; ++w) {
    const std::uint64_t word = rng();
    for (std::size_t b = 0; b < 8; ++b) d.bytes[8 * w + b] = static_cast<std::uint8_t>(word >> (8 * b));
  }
  return d;
}

/// `d` with `bits` bits flipped (distinct positions).
Descriptor flipped(Descriptor d, int bits, std::mt19937_64& rng) {
  std::vector<int> positions(256);
  for (int i = 0; i < 256; ++i) positions[static_cast<std::size_t>(i)] = i;
  std::shuffle(positions.begin(), positions.end(), rng);
  for (int i = 0; i < bits; ++i) {
    const int p = positions[static_cast<std::size_t>(i)];
    d.bytes[static_cast<std::size_t>(p / 8)] ^= static_cast<std::uint8_t>(1u << (p % 8));
  }
  return d;
}

/// The scan the planes replace: candidates in order, strict comparisons.
detail::Nearest sequential_nearest(const Descriptor& query, const std::vector<Descriptor>& descriptors,
                                   const std::vector<int>& which) {
  detail::Nearest r;
  for (std::size_t k = 0; k < which.size(); ++k) {
    const int d = hamming_distance(query, descriptors[static_cast<std::size_t>(which[k])]);
    if (d < r.best) {
      r.second = r.best;
      r.best = d;
      r.index = static_cast<int>(k);
    } else if (d < r.second) {
      r.second = d;
    }
  }
  return r;
}

/// Candidates with planted near and exact copies of the queries (ties at the best and second
/// distance), listed in a shuffled order with gaps.
struct Scene {
  std::vector<Descriptor> queries, candidates;
  std::vector<int> which;
};
Scene make_scene(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Scene s;
  for (int q = 0; q < 40; ++q) s.queries.push_back(random_descriptor(rng));
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint64_t kind = rng() % 4;
    const Descriptor& q = s.queries[static_cast<std::size_t>(rng() % s.queries.size())];
    if (kind == 0) s.candidates.push_back(q);                                       // exact: ties at 0
    else if (kind == 1) s.candidates.push_back(flipped(q, static_cast<int>(rng() % 40), rng));  // near
    else s.candidates.push_back(random_descriptor(rng));                           // ~128 away
  }
  for (std::size_t k = 0; k < n; ++k) {
    if (rng() % 5 != 0) s.which.push_back(static_cast<int>(k));
  }
  std::shuffle(s.which.begin(), s.which.end(), rng);
  return s;
}

TEST(DescriptorScan, DistancesAreTheHammingDistances) {
  for (const bool vector_popcount : {false, true}) {
    const Scene s = make_scene(301, 7);
    const detail::DescriptorPlanes planes(s.candidates, s.which);
    ASSERT_EQ(planes.size(), s.which.size());
    std::vector<std::uint16_t> out(planes.size(), 999);
    for (const Descriptor& q : s.queries) {
      planes.distances(q, out.data(), vector_popcount);
      for (std::size_t k = 0; k < s.which.size(); ++k) {
        ASSERT_EQ(out[k], hamming_distance(q, s.candidates[static_cast<std::size_t>(s.which[k])]))
            << "candidate " << k << (vector_popcount ? " (vector path)" : " (portable path)");
      }
    }
  }
}

TEST(DescriptorScan, NearestIsWhatTheSequentialScanFinds) {
  // Sizes around the vector widths (8 words, 32 distances) and the empty and single cases.
  for (const std::size_t n : {0u, 1u, 2u, 3u, 7u, 8u, 9u, 31u, 32u, 33u, 64u, 65u, 1000u}) {
    const Scene s = make_scene(n, 100 + n);
    const detail::DescriptorPlanes planes(s.candidates, s.which);
    std::vector<std::uint16_t> scratch;
    int ties = 0;
    for (const bool vector_popcount : {false, true}) {
      for (const Descriptor& q : s.queries) {
        const detail::Nearest want = sequential_nearest(q, s.candidates, s.which);
        const detail::Nearest got = planes.nearest(q, scratch, vector_popcount);
        ASSERT_EQ(got.index, want.index) << "n " << n;
        ASSERT_EQ(got.best, want.best) << "n " << n;
        ASSERT_EQ(got.second, want.second) << "n " << n;
        if (want.index >= 0 && want.best == want.second) ++ties;
      }
    }
    if (n >= 1000) {
      EXPECT_GT(ties, 0) << "the scene should hold ties at the best distance";
    }
  }
}

TEST(DescriptorScan, EmptyCandidatesFindNothing) {
  const detail::DescriptorPlanes planes({}, {});
  std::vector<std::uint16_t> scratch;
  const detail::Nearest r = planes.nearest(Descriptor{}, scratch);
  EXPECT_EQ(r.index, -1);
  EXPECT_EQ(r.best, 257);
  EXPECT_EQ(r.second, 257);
}

/// match_by_descriptor as it was before the planes: the candidates scanned through `from_b`.
std::vector<FeatureMatch> reference_match(const FrameFeatures& a, const std::vector<int>& from_a,
                                          const FrameFeatures& b, const std::vector<int>& from_b, int max_distance,
                                          double ratio) {
  std::vector<int> owner(b.size(), -1);
  std::vector<FeatureMatch> found;
  for (const int i : from_a) {
    const detail::Nearest n = sequential_nearest(a.descriptors[static_cast<std::size_t>(i)], b.descriptors, from_b);
    if (n.index < 0 || n.best > max_distance || n.best >= ratio * n.second) continue;
    const int j = from_b[static_cast<std::size_t>(n.index)];
    int& o = owner[static_cast<std::size_t>(j)];
    if (o >= 0) {
      if (found[static_cast<std::size_t>(o)].distance <= n.best) continue;
      found[static_cast<std::size_t>(o)].feature1 = -1;
    }
    o = static_cast<int>(found.size());
    found.push_back({i, j, n.best});
  }
  std::vector<FeatureMatch> matches;
  for (const FeatureMatch& m : found) {
    if (m.feature1 >= 0) matches.push_back(m);
  }
  keep_consistent_rotations(matches, a, b);
  return matches;
}

FrameFeatures features_of(const std::vector<Descriptor>& descriptors, std::mt19937_64& rng) {
  FrameFeatures f;
  for (const Descriptor& d : descriptors) {
    f.uv.emplace_back(0.0f, 0.0f);
    f.level.push_back(0);
    // Mostly one orientation change, some others: the rotation filter keeps and drops matches.
    f.angle_rad.push_back(rng() % 6 == 0 ? static_cast<float>(rng() % 628) / 100.0f : 1.0f);
    f.descriptors.push_back(d);
    f.u_right.push_back(-1.0f);
    f.depth_m.push_back(-1.0f);
  }
  return f;
}

TEST(DescriptorScan, MatchByDescriptorIsTheSequentialMatching) {
  std::mt19937_64 rng(42);
  std::vector<Descriptor> da, db;
  for (int i = 0; i < 600; ++i) da.push_back(random_descriptor(rng));
  for (int j = 0; j < 700; ++j) {
    // A third copies an `a` feature within 0-60 bits (some shared by two `b` features: ownership).
    if (rng() % 3 == 0) {
      const Descriptor& source = da[static_cast<std::size_t>(rng() % da.size())];
      db.push_back(flipped(source, static_cast<int>(rng() % 60), rng));
    } else {
      db.push_back(random_descriptor(rng));
    }
  }
  const FrameFeatures a = features_of(da, rng);
  const FrameFeatures b = features_of(db, rng);
  std::vector<int> from_a, from_b;
  for (int i = 0; i < 600; ++i) {
    if (rng() % 4 != 0) from_a.push_back(i);
  }
  for (int j = 0; j < 700; ++j) {
    if (rng() % 4 != 0) from_b.push_back(j);
  }
  for (const double ratio : {0.6, 0.75, 1.0}) {
    const std::vector<FeatureMatch> want = reference_match(a, from_a, b, from_b, 50, ratio);
    const std::vector<FeatureMatch> got = match_by_descriptor(a, from_a, b, from_b, 50, ratio);
    ASSERT_GT(want.size(), 20u);
    ASSERT_EQ(got.size(), want.size()) << "ratio " << ratio;
    for (std::size_t m = 0; m < want.size(); ++m) {
      EXPECT_EQ(got[m].feature1, want[m].feature1);
      EXPECT_EQ(got[m].feature2, want[m].feature2);
      EXPECT_EQ(got[m].distance, want[m].distance);
    }
  }
}

}  // namespace
}  // namespace porta::slam
