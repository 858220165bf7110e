// Stereo matching and projection matching of the cpu backend (DESIGN.md §3.9, §3.10): the
// integer helpers by hand-worked values, each candidate filter at its bound, the tie rules, the
// median rejection, and both kernels against naive full-scan re-implementations, byte for byte.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "cpu/cpu_backend.hpp"
#include "cpu/stereo_math.hpp"
#include "porta/frontend.hpp"
#include "porta/tables.hpp"
#include "support/test_images.hpp"

namespace porta {
namespace {

using cpu::CpuBackend;

constexpr double kScale = 1.2;  // S = {65536, 78643, 94372, 113246} for levels 0..3

// ---- Deterministic inputs --------------------------------------------------------------------

std::uint64_t next_random(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
int random_below(std::uint64_t& state, int n) {
  return static_cast<int>(next_random(state) % static_cast<std::uint64_t>(n));
}

Descriptor random_descriptor(std::uint64_t& state) {
  Descriptor d;
  for (auto& b : d.bytes) b = static_cast<std::uint8_t>(next_random(state));
  return d;
}
/// `d` with its first `bits` bits inverted: exactly `bits` away from `d`.
Descriptor flip_first_bits(Descriptor d, int bits) {
  for (int b = 0; b < bits; ++b) d.bytes[static_cast<std::size_t>(b / 8)] ^= static_cast<std::uint8_t>(1u << (b % 8));
  return d;
}
Keypoint kp(int x, int y, int level) {
  Keypoint k;
  k.x = static_cast<std::uint16_t>(x);
  k.y = static_cast<std::uint16_t>(y);
  k.response = 100;
  k.level = static_cast<std::uint8_t>(level);
  return k;
}

// ---- Device plumbing -------------------------------------------------------------------------

struct DeviceKeypoints {
  std::unique_ptr<Buffer> items, count, descriptors;
  int n = 0;
  ConstDeviceList list() const {
    ConstDeviceList l;
    l.items = items.get();
    l.count = count.get();
    l.capacity = n;
    return l;
  }
};

DeviceKeypoints upload_keypoints(CpuBackend& backend, const std::vector<Keypoint>& kps,
                                 const std::vector<Descriptor>& descriptors) {
  DeviceKeypoints d;
  d.n = static_cast<int>(kps.size());
  d.items = backend.allocate(kps.size() * sizeof(Keypoint));
  d.descriptors = backend.allocate(descriptors.size() * sizeof(Descriptor));
  d.count = backend.allocate(sizeof(std::uint32_t));
  backend.upload(*d.items, 0, kps.data(), kps.size() * sizeof(Keypoint));
  backend.upload(*d.descriptors, 0, descriptors.data(), descriptors.size() * sizeof(Descriptor));
  const auto n = static_cast<std::uint32_t>(kps.size());
  backend.upload(*d.count, 0, &n, sizeof(n));
  return d;
}

/// Per level n: `right[n]` is a texture, `left[n]` the same shifted right by shifts[n] px, so the
/// left pixel x shows the right pixel x - shifts[n] (disparity shifts[n] at that level). `noise`
/// perturbs the right third of each right level by up to +-noise, so SADs there are not 0.
struct StereoScene {
  std::vector<std::pair<int, int>> sizes;
  std::vector<Image> left, right;
  StereoParams params;
};

StereoScene make_scene(int width, int height, const std::vector<int>& shifts, std::uint64_t seed, int noise = 0) {
  StereoScene s;
  const int levels = static_cast<int>(shifts.size());
  s.sizes = pyramid_level_sizes(width, height, levels, kScale);
  std::uint64_t state = seed;
  for (int n = 0; n < levels; ++n) {
    Image base =
        test::textured_image(s.sizes[static_cast<std::size_t>(n)].first, s.sizes[static_cast<std::size_t>(n)].second,
                             seed + static_cast<std::uint64_t>(n));
    s.left.push_back(test::shifted_right(base, shifts[static_cast<std::size_t>(n)]));
    for (int y = 0; noise > 0 && y < base.height(); ++y)
      for (int x = base.width() * 2 / 3; x < base.width(); ++x)
        base.at(x, y) =
            static_cast<std::uint8_t>(std::clamp(base.at(x, y) + random_below(state, 2 * noise + 1) - noise, 0, 255));
    s.right.push_back(std::move(base));
  }
  s.params.scales_q16 = build_level_scales_q16(levels, kScale);
  s.params.row_radius_q8 = build_stereo_row_radius_q8(levels, kScale);
  return s;
}

std::unique_ptr<Buffer> upload_pyramid(CpuBackend& backend, const PyramidLayout& layout,
                                       const std::vector<Image>& levels) {
  auto buffer = backend.allocate(static_cast<std::size_t>(layout.total_bytes));
  for (std::size_t n = 0; n < levels.size(); ++n) {
    const Plane& p = layout.levels[n];
    for (int y = 0; y < p.height; ++y)
      backend.upload(*buffer, static_cast<std::size_t>(p.offset_bytes + static_cast<std::int64_t>(y) * p.pitch),
                     levels[n].row(y), static_cast<std::size_t>(p.width));
  }
  return buffer;
}

std::vector<StereoMatch> run_stereo(CpuBackend& backend, const StereoScene& scene, const std::vector<Keypoint>& lk,
                                    const std::vector<Descriptor>& ld, const std::vector<Keypoint>& rk,
                                    const std::vector<Descriptor>& rd) {
  const PyramidLayout layout = PyramidLayout::make(scene.sizes, 1);
  const auto left = upload_pyramid(backend, layout, scene.left);
  const auto right = upload_pyramid(backend, layout, scene.right);
  const DeviceKeypoints l = upload_keypoints(backend, lk, ld), r = upload_keypoints(backend, rk, rd);
  auto matches = backend.allocate(lk.size() * sizeof(StereoMatch));
  backend.fill(*matches, 0, matches->size_bytes(), 0x7F);  // every entry must be overwritten
  backend.stereo_match(*left, *right, layout, l.list(), *l.descriptors, r.list(), *r.descriptors, scene.params,
                       *matches);
  std::vector<StereoMatch> out(lk.size());
  backend.download(*matches, 0, out.data(), out.size() * sizeof(StereoMatch));
  return out;
}

/// One left keypoint against a right list, all at level 0 of `scene`; returns its match.
StereoMatch match_one(const StereoScene& scene, const Keypoint& left, const std::vector<Keypoint>& right,
                      const std::vector<int>& distances) {
  std::uint64_t state = 99;
  const Descriptor d = random_descriptor(state);
  std::vector<Descriptor> rd;
  for (int dist : distances) rd.push_back(flip_first_bits(d, dist));
  CpuBackend backend(2);
  return run_stereo(backend, scene, {left}, {d}, right, rd)[0];
}

// ---- Naive re-implementations (full scans in index order, written independently) -------------

int naive_hamming(const Descriptor& a, const Descriptor& b) {
  int d = 0;
  for (int bit = 0; bit < 256; ++bit)
    d += ((a.bytes[static_cast<std::size_t>(bit / 8)] ^ b.bytes[static_cast<std::size_t>(bit / 8)]) >> (bit % 8)) & 1;
  return d;
}
std::int64_t naive_pos_q8(int c, std::int32_t s) { return (static_cast<std::int64_t>(c) * s + 128) / 256; }

struct NaiveStereo {
  std::vector<StereoMatch> matches;
  int rejected_by_median = 0;
};

NaiveStereo naive_stereo(const StereoScene& scene, const std::vector<Keypoint>& lk, const std::vector<Descriptor>& ld,
                         const std::vector<Keypoint>& rk, const std::vector<Descriptor>& rd) {
  const StereoParams& p = scene.params;
  const auto& S = p.scales_q16;
  const int levels = static_cast<int>(scene.sizes.size());
  NaiveStereo out;
  out.matches.assign(lk.size(), StereoMatch{});
  std::vector<std::int64_t> sad_of(lk.size(), -1);
  for (std::size_t i = 0; i < lk.size(); ++i) {
    const Keypoint& a = lk[i];
    const int n = a.level;
    if (n >= levels) continue;
    const std::int64_t ul = naive_pos_q8(a.x, S[n]), vl = naive_pos_q8(a.y, S[n]);
    int best = -1, best_distance = 0;
    for (std::size_t j = 0; j < rk.size(); ++j) {
      const Keypoint& b = rk[j];
      if (b.level >= levels || std::abs(b.level - n) > 1) continue;
      const std::int64_t ur = naive_pos_q8(b.x, S[b.level]), vr = naive_pos_q8(b.y, S[b.level]);
      if (std::abs(vl - vr) > p.row_radius_q8[b.level]) continue;
      if (ul - ur < p.min_disparity_q8 || ul - ur > p.max_disparity_q8) continue;
      const int distance = naive_hamming(ld[i], rd[j]);
      if (best < 0 || distance < best_distance) {
        best = static_cast<int>(j);
        best_distance = distance;
      }
    }
    if (best < 0 || best_distance >= p.max_hamming) continue;

    const Keypoint& b = rk[static_cast<std::size_t>(best)];
    const Image& L = scene.left[static_cast<std::size_t>(n)];
    const Image& R = scene.right[static_cast<std::size_t>(n)];
    const int w = L.width(), h = L.height();
    std::int64_t xr = b.x;
    if (b.level != n) {
      const std::int64_t ratio = (static_cast<std::int64_t>(S[b.level]) * 65536 + S[n] / 2) / S[n];
      xr = (b.x * ratio + 32768) / 65536;
    }
    if (xr < 10 || xr > w - 11 || a.x < 5 || a.x > w - 6 || a.y < 5 || a.y > h - 6) continue;
    std::int64_t sads[11];
    for (int inc = -5; inc <= 5; ++inc) {
      const int xc = static_cast<int>(xr) + inc;
      std::int64_t sum = 0;
      for (int y = a.y - 5; y <= a.y + 5; ++y)
        for (int x = -5; x <= 5; ++x)
          sum += std::abs((L.at(a.x + x, y) - L.at(a.x, a.y)) - (R.at(xc + x, y) - R.at(xc, a.y)));
      sads[inc + 5] = sum;
    }
    int k = 0;
    for (int c = 1; c < 11; ++c)
      if (sads[c] < sads[k]) k = c;
    if (k == 0 || k == 10) continue;
    const std::int64_t d1 = sads[k - 1], d2 = sads[k], d3 = sads[k + 1];
    const std::int64_t den = 2 * (d1 + d3 - 2 * d2);
    if (std::abs(d1 - d3) > den) continue;
    const std::int64_t num = (d1 - d3) * 256;
    std::int64_t q = std::abs(num) / den;
    if (2 * (std::abs(num) % den) >= den) ++q;  // half away from zero
    const std::int64_t delta = num < 0 ? -q : q;
    const std::int64_t dn = (a.x - xr - (k - 5)) * 256 - delta;
    if (dn < 0) continue;
    const std::int64_t d0 = (dn * S[n] + 32768) / 65536;
    if (d0 < p.min_disparity_q8 || d0 > p.max_disparity_q8) continue;
    out.matches[i] = StereoMatch{static_cast<std::int32_t>(d0), best};
    sad_of[i] = d2;
  }
  std::vector<std::int64_t> sorted;
  for (auto s : sad_of)
    if (s >= 0) sorted.push_back(s);
  std::sort(sorted.begin(), sorted.end());
  if (sorted.empty()) return out;
  const std::int64_t median = sorted[sorted.size() / 2];
  for (std::size_t i = 0; i < lk.size(); ++i)
    if (sad_of[i] >= 0 && sad_of[i] * 10 > 21 * median) {
      out.matches[i] = StereoMatch{};
      ++out.rejected_by_median;
    }
  return out;
}

std::vector<ProjectionResult> naive_projection(const std::vector<Keypoint>& kps, const std::vector<Descriptor>& kd,
                                               const std::vector<ProjectionQuery>& queries,
                                               const std::vector<Descriptor>& qd, const std::vector<std::int32_t>& S) {
  std::vector<ProjectionResult> out(queries.size());
  for (std::size_t q = 0; q < queries.size(); ++q) {
    const ProjectionQuery& query = queries[q];
    std::vector<int> candidates;
    for (std::size_t k = 0; k < kps.size(); ++k) {
      const Keypoint& c = kps[k];
      if (static_cast<std::size_t>(c.level) >= S.size() || c.level < query.min_level || c.level > query.max_level)
        continue;
      if (std::abs(naive_pos_q8(c.x, S[c.level]) - query.u_q8) > query.radius_q8) continue;
      if (std::abs(naive_pos_q8(c.y, S[c.level]) - query.v_q8) > query.radius_q8) continue;
      candidates.push_back(static_cast<int>(k));
    }
    ProjectionResult& r = out[q];
    for (int k : candidates) {
      const int d = naive_hamming(qd[q], kd[static_cast<std::size_t>(k)]);
      if (r.best_index < 0 || d < r.best_distance) {
        r.best_index = k;
        r.best_distance = d;
      }
    }
    for (int k : candidates)
      if (k != r.best_index)
        r.second_distance = std::min(r.second_distance, naive_hamming(qd[q], kd[static_cast<std::size_t>(k)]));
  }
  return out;
}

template <typename T>
void expect_same_bytes(const std::vector<T>& got, const std::vector<T>& want, const char* what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t i = 0; i < got.size(); ++i)
    ASSERT_EQ(std::memcmp(&got[i], &want[i], sizeof(T)), 0) << what << ": first difference at element " << i;
}

// ---- Integer helpers (stereo_math.hpp) ------------------------------------------------------

TEST(StereoMath, Level0PositionRoundsToNearestQ8) {
  EXPECT_EQ(cpu::stereo::level0_q8(10, 65536), 2560);
  // 50 * 78643 = 3932150; (3932150 + 128) >> 8 = 15360 (15360.4 rounded down).
  EXPECT_EQ(cpu::stereo::level0_q8(50, 78643), 15360);
  // 52 * 78643 = 4089436; (4089436 + 128) / 256 = 15974.86 -> 15974: the bias is 1/2 of a q8 step.
  EXPECT_EQ(cpu::stereo::level0_q8(52, 78643), 15974);
}

TEST(StereoMath, HammingCountsDifferingBits) {
  std::uint64_t state = 1;
  const Descriptor a = random_descriptor(state);
  EXPECT_EQ(cpu::stereo::hamming_distance(a, a), 0);
  EXPECT_EQ(cpu::stereo::hamming_distance(a, flip_first_bits(a, 75)), 75);
  EXPECT_EQ(cpu::stereo::hamming_distance(a, flip_first_bits(a, 256)), 256);
}

TEST(StereoMath, LevelRatioAndColumnScalingRoundHalfUp) {
  // Level 1 -> 0: (78643 * 65536 + 32768) / 65536 = 78643; 77 * 78643 = 6055511, + 32768 >> 16 = 92.9 -> 92.
  EXPECT_EQ(cpu::stereo::level_ratio_q16(78643, 65536), 78643);
  EXPECT_EQ(cpu::stereo::scale_column(77, 78643), 92);
  // Level 2 -> 1: (94372 * 65536 + 39321) / 78643 = 78644.0 -> 78644 (1.2000122 in Q16).
  EXPECT_EQ(cpu::stereo::level_ratio_q16(94372, 78643), 78644);
  // Level 0 -> 1: (65536 * 65536 + 39321) / 78643 = 54613.8 -> 54613 (integer division after +S/2).
  EXPECT_EQ(cpu::stereo::level_ratio_q16(65536, 78643), 54613);
  // 100 * 54613 = 5461300; + 32768 = 5494068; >> 16 = 83.8 -> 83.
  EXPECT_EQ(cpu::stereo::scale_column(100, 54613), 83);
}

TEST(StereoMath, ParabolaDeltaRoundsHalfAwayFromZero) {
  std::int32_t delta = 0;
  // d = (30, 10, 20): den = 2 * (30 + 20 - 20) = 60, num = 10 * 256 = 2560, 2560 / 60 = 42.67 -> 43.
  ASSERT_TRUE(cpu::stereo::parabola_delta_q8(30, 10, 20, delta));
  EXPECT_EQ(delta, 43);
  ASSERT_TRUE(cpu::stereo::parabola_delta_q8(20, 10, 30, delta));
  EXPECT_EQ(delta, -43);
  // d = (259, 0, 253): den = 1024, num = 1536, 1.5 exactly -> 2; mirrored -> -2 (not -1).
  ASSERT_TRUE(cpu::stereo::parabola_delta_q8(259, 0, 253, delta));
  EXPECT_EQ(delta, 2);
  ASSERT_TRUE(cpu::stereo::parabola_delta_q8(253, 0, 259, delta));
  EXPECT_EQ(delta, -2);
  // d = (771, 0, 765): den = 3072, num = 1536, 0.5 -> 1; symmetric neighbours give 0.
  ASSERT_TRUE(cpu::stereo::parabola_delta_q8(771, 0, 765, delta));
  EXPECT_EQ(delta, 1);
  ASSERT_TRUE(cpu::stereo::parabola_delta_q8(40, 0, 40, delta));
  EXPECT_EQ(delta, 0);
  // A perfect match beside one neighbour of equal SAD: d = (1, 0, 0): den = 2, 256 / 2 = 128 (half a pixel).
  ASSERT_TRUE(cpu::stereo::parabola_delta_q8(1, 0, 0, delta));
  EXPECT_EQ(delta, 128);
}

TEST(StereoMath, ParabolaRejectsNonMinimumAndFlatTriples) {
  std::int32_t delta = 7;
  // Not a minimum at the centre: d = (0, 10, 30): den = 20 < |d1 - d3| = 30, vertex 1.5 px away.
  EXPECT_FALSE(cpu::stereo::parabola_delta_q8(0, 10, 30, delta));
  EXPECT_FALSE(cpu::stereo::parabola_delta_q8(5, 5, 5, delta));  // den = 0
  EXPECT_EQ(delta, 7) << "the output is left untouched on rejection";
}

TEST(StereoMath, Level0DisparityRoundsHalfUp) {
  // 10 px at level 1: (2560 * 78643 + 32768) >> 16 = 3072.49 -> 3072 (= 12 px).
  EXPECT_EQ(cpu::stereo::level0_disparity_q8(2560, 78643), 3072);
  EXPECT_EQ(cpu::stereo::level0_disparity_q8(2048, 65536), 2048);
  // 1 q8 at level 1: (78643 + 32768) >> 16 = 1 (1.7 rounded half up? 111411 / 65536 = 1.70 -> 1).
  EXPECT_EQ(cpu::stereo::level0_disparity_q8(1, 78643), 1);
  EXPECT_EQ(cpu::stereo::level0_disparity_q8(0, 78643), 0);
}

TEST(StereoMath, MedianIsUpperMiddleAndOutliersExceed2Point1Times) {
  EXPECT_EQ(cpu::stereo::median_sad({5, 1, 3, 2}), 3);  // sorted 1 2 3 5, index 4 / 2 = 2
  EXPECT_EQ(cpu::stereo::median_sad({30, 10, 20}), 20);
  EXPECT_EQ(cpu::stereo::median_sad({7}), 7);
  EXPECT_FALSE(cpu::stereo::sad_is_outlier(42, 20));  // 420 > 420 is false
  EXPECT_TRUE(cpu::stereo::sad_is_outlier(43, 20));
  EXPECT_FALSE(cpu::stereo::sad_is_outlier(0, 0));
  EXPECT_TRUE(cpu::stereo::sad_is_outlier(1, 0));  // with a perfect median, any imperfect match goes
}

// ---- stereo_match: whole kernel on constructed scenes ----------------------------------------

// A grid of level-0 keypoints on a texture shifted by 8 px, the right list being the same points
// at x - 8 with the same descriptors. At the true increment SAD is 0, so the parabola moves the
// estimate by (d1 - d3) / (2 (d1 + d3)), at most half a pixel: |d0 - 8 * 256| <= 128, exact only
// when SAD(-1) = SAD(+1). (On this texture the error's median is 19 q8 and its maximum 72.)
TEST(StereoMatch, RecoversKnownShiftOfTexturedImage) {
  constexpr int kShift = 8;
  const StereoScene scene = make_scene(240, 160, {kShift}, 11);
  std::vector<Keypoint> lk, rk;
  std::vector<Descriptor> ld;
  std::uint64_t state = 5;
  for (int y = 20; y <= 140; y += 12)
    for (int x = 30; x <= 210; x += 12) {
      lk.push_back(kp(x, y, 0));
      rk.push_back(kp(x - kShift, y, 0));
      ld.push_back(random_descriptor(state));
    }
  CpuBackend backend(2);
  const auto matches = run_stereo(backend, scene, lk, ld, rk, ld);
  std::vector<int> errors;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (matches[i].right_index < 0) {
      EXPECT_EQ(matches[i].disparity_q8, -1);
      continue;
    }
    EXPECT_EQ(matches[i].right_index, static_cast<int>(i));
    errors.push_back(std::abs(matches[i].disparity_q8 - kShift * 256));
    EXPECT_LE(errors.back(), 128) << "keypoint " << i;
  }
  ASSERT_GE(errors.size() * 10, matches.size() * 9);
  std::sort(errors.begin(), errors.end());
  EXPECT_EQ(errors.front(), 0);
  EXPECT_LE(errors[errors.size() / 2], 32);  // a smooth texture gives nearly symmetric SAD curves
  expect_same_bytes(matches, naive_stereo(scene, lk, ld, rk, ld).matches, "naive");
}

// Level-1 keypoints on a level-1 texture shifted by 6 px: d0 = 6 px * 1.2 = 7.2 px = 1843 q8
// ((1536 * 78643 + 32768) >> 16), give or take half a level-1 pixel (154 q8).
TEST(StereoMatch, Level1DisparitiesAreScaledToLevel0) {
  const StereoScene scene = make_scene(240, 160, {8, 6}, 12);
  std::vector<Keypoint> lk, rk;
  std::vector<Descriptor> ld;
  std::uint64_t state = 6;
  for (int y = 20; y <= 110; y += 15)
    for (int x = 30; x <= 170; x += 14) {
      lk.push_back(kp(x, y, 1));
      rk.push_back(kp(x - 6, y, 1));
      ld.push_back(random_descriptor(state));
    }
  CpuBackend backend(2);
  const auto matches = run_stereo(backend, scene, lk, ld, rk, ld);
  int matched = 0;
  for (const auto& m : matches) {
    if (m.right_index < 0) continue;
    ++matched;
    EXPECT_LE(std::abs(m.disparity_q8 - 1843), 154);
  }
  EXPECT_GE(matched * 10, static_cast<int>(matches.size()) * 9);
}

// Left keypoint (100, 60) at level 0, true right column 92. Right 0: the true point at distance 5;
// right 1: distance 0, placed at each side of the row band. Level 0: radius 512 q8 = 2 px.
// Level 1: radius 614 q8; v = (y * 78643 + 128) >> 8 gives 14438, 14746, 15974, 16282 for
// y = 47, 48, 52, 53 against vL = 15360: 48 and 52 lie exactly on the band's edge.
TEST(StereoMatch, RowBandIsInclusiveAtEachLevel) {
  const StereoScene scene = make_scene(240, 160, {8, 7}, 13);
  const Keypoint left = kp(100, 60, 0);
  auto chosen = [&](Keypoint other) { return match_one(scene, left, {kp(92, 60, 0), other}, {5, 0}).right_index; };
  EXPECT_EQ(chosen(kp(92, 62, 0)), 1);
  EXPECT_EQ(chosen(kp(92, 58, 0)), 1);
  EXPECT_EQ(chosen(kp(92, 63, 0)), 0);
  EXPECT_EQ(chosen(kp(92, 57, 0)), 0);
  // Level 1 column 77 is level-0 column 92 ((77 * 78643 + 32768) >> 16).
  EXPECT_EQ(chosen(kp(77, 52, 1)), 1);
  EXPECT_EQ(chosen(kp(77, 48, 1)), 1);
  EXPECT_EQ(chosen(kp(77, 53, 1)), 0);
  EXPECT_EQ(chosen(kp(77, 47, 1)), 0);
}

// Left keypoint (100, 60), true right column 92 (disparity 8 px). Right 1 (distance 0) sits at a
// disparity of 10 px or 6 px; it is a candidate exactly when that lies in [min, max], and the SAD
// search (+-5 px) then still finds the true column.
TEST(StereoMatch, DisparityRangeIsInclusive) {
  StereoScene scene = make_scene(240, 160, {8}, 14);
  const Keypoint left = kp(100, 60, 0);
  auto chosen = [&](int other_x) { return match_one(scene, left, {kp(92, 60, 0), kp(other_x, 60, 0)}, {5, 0}); };
  scene.params.max_disparity_q8 = 10 * 256;
  EXPECT_EQ(chosen(90).right_index, 1);
  EXPECT_LE(std::abs(chosen(90).disparity_q8 - 8 * 256), 128);
  scene.params.max_disparity_q8 = 10 * 256 - 1;
  EXPECT_EQ(chosen(90).right_index, 0);
  scene.params.max_disparity_q8 = 128 * 256;
  scene.params.min_disparity_q8 = 6 * 256;
  EXPECT_EQ(chosen(94).right_index, 1);
  scene.params.min_disparity_q8 = 6 * 256 + 1;
  EXPECT_EQ(chosen(94).right_index, 0);
  // The refined disparity must itself lie in the range: none when the range excludes 8 px.
  scene.params.min_disparity_q8 = 0;
  scene.params.max_disparity_q8 = 7 * 256;
  EXPECT_EQ(match_one(scene, left, {kp(94, 60, 0)}, {0}).right_index, -1);
}

// Left keypoint at level 1 (100, 60), true level-1 column 93. Right keypoints at the same point,
// all at distance 0: index 0 at level 3 (two levels away, never a candidate), index 1 at level 2,
// index 2 at level 0. The lowest candidate index wins: 1; with index 1 at distance 1: index 2.
TEST(StereoMatch, LevelBandIsPlusMinusOne) {
  const StereoScene scene = make_scene(240, 160, {8, 7, 6, 5}, 15);
  std::uint64_t state = 3;
  const Descriptor d = random_descriptor(state);
  const std::vector<Keypoint> right = {kp(65, 42, 3), kp(78, 50, 2), kp(112, 72, 0)};
  CpuBackend backend(2);
  EXPECT_EQ(run_stereo(backend, scene, {kp(100, 60, 1)}, {d}, right, {d, d, d})[0].right_index, 1);
  EXPECT_EQ(run_stereo(backend, scene, {kp(100, 60, 1)}, {d}, right, {d, flip_first_bits(d, 1), d})[0].right_index, 2);
  // Without the level-2 and level-0 points the level-3 one is alone and still not taken.
  EXPECT_EQ(run_stereo(backend, scene, {kp(100, 60, 1)}, {d}, {right[0]}, {d})[0].right_index, -1);
}

TEST(StereoMatch, HammingTiesGoToLowerIndexAndBestMustBeBelowThreshold) {
  StereoScene scene = make_scene(240, 160, {8}, 16);
  const Keypoint left = kp(100, 60, 0);
  const std::vector<Keypoint> right = {kp(92, 60, 0), kp(91, 60, 0)};
  EXPECT_EQ(match_one(scene, left, right, {3, 3}).right_index, 0);
  EXPECT_EQ(match_one(scene, left, right, {3, 2}).right_index, 1);
  EXPECT_EQ(match_one(scene, left, {kp(91, 60, 0), kp(92, 60, 0)}, {3, 3}).right_index, 0);
  scene.params.max_hamming = 3;  // best distance 3 is not below 3
  EXPECT_EQ(match_one(scene, left, {right[0]}, {3}).right_index, -1);
  scene.params.max_hamming = 4;
  EXPECT_EQ(match_one(scene, left, {right[0]}, {3}).right_index, 0);
}

// Shift 3 px, right keypoints placed 2 px off the truth so that the SAD search runs at inc = +-2.
// The search reads columns xR - 10 .. xR + 10 of the right level and the left window
// xL - 5 .. xL + 5, yL - 5 .. yL + 5: a match needs all of them inside the level (W = 240, H = 160).
TEST(StereoMatch, SadWindowsMustFitInsideTheLevel) {
  const StereoScene scene = make_scene(240, 160, {3}, 17);
  auto match = [&](int xl, int yl, int xr) { return match_one(scene, kp(xl, yl, 0), {kp(xr, yl, 0)}, {0}); };
  EXPECT_EQ(match(15, 60, 10).right_index, 0);     // xR - 10 = 0
  EXPECT_EQ(match(14, 60, 9).right_index, -1);     // xR - 10 < 0
  EXPECT_EQ(match(230, 60, 229).right_index, 0);   // xR + 10 = 239 = W - 1
  EXPECT_EQ(match(231, 60, 230).right_index, -1);  // xR + 10 = W
  EXPECT_EQ(match(100, 5, 99).right_index, 0);     // yL - 5 = 0
  EXPECT_EQ(match(100, 4, 99).right_index, -1);
  EXPECT_EQ(match(100, 154, 99).right_index, 0);  // yL + 5 = H - 1
  EXPECT_EQ(match(100, 155, 99).right_index, -1);
  EXPECT_LE(std::abs(match(15, 60, 10).disparity_q8 - 3 * 256), 128);
}

// Five exact matches (SAD 0 at the true column) and one whose right window has one pixel changed
// by 40: its SAD is positive, the median is 0, so it is dropped (sad * 10 > 21 * 0). Alone, it is
// its own median and kept.
TEST(StereoMatch, MedianSadRejectionDropsTheOutlier) {
  StereoScene scene = make_scene(240, 160, {8}, 18);
  std::vector<Keypoint> lk, rk;
  for (int k = 0; k < 6; ++k) {
    lk.push_back(kp(40 + 30 * k, 80, 0));
    rk.push_back(kp(32 + 30 * k, 80, 0));
  }
  // Perturb the right window of keypoint 3 (true column 122) off its centre.
  std::uint8_t& px = scene.right[0].at(124, 81);
  px = static_cast<std::uint8_t>(px < 128 ? px + 40 : px - 40);
  std::uint64_t state = 8;
  std::vector<Descriptor> ld;
  for (int k = 0; k < 6; ++k) ld.push_back(random_descriptor(state));
  CpuBackend backend(2);
  const auto matches = run_stereo(backend, scene, lk, ld, rk, ld);
  for (int k = 0; k < 6; ++k) EXPECT_EQ(matches[static_cast<std::size_t>(k)].right_index, k == 3 ? -1 : k) << k;
  EXPECT_EQ(matches[3].disparity_q8, -1);
  const auto alone = run_stereo(backend, scene, {lk[3]}, {ld[3]}, {rk[3]}, {ld[3]});
  EXPECT_EQ(alone[0].right_index, 0);
}

TEST(StereoMatch, EmptyListsAndMismatchedParams) {
  const StereoScene scene = make_scene(64, 48, {2, 2}, 19);
  CpuBackend backend(2);
  EXPECT_TRUE(run_stereo(backend, scene, {}, {}, {}, {}).empty());
  std::uint64_t state = 4;
  const Descriptor d = random_descriptor(state);
  EXPECT_EQ(run_stereo(backend, scene, {kp(30, 20, 0)}, {d}, {}, {})[0].right_index, -1);
  StereoScene bad = scene;
  bad.params.row_radius_q8.pop_back();
  EXPECT_THROW(run_stereo(backend, bad, {kp(30, 20, 0)}, {d}, {}, {}), BackendError);
}

// Random keypoints on all levels (borders included), right keypoints near the truth at levels
// n - 1 .. n + 1 with 0-99 flipped bits, duplicates for index ties, noise in the right third of
// the right images so that SADs differ and the median cut bites; compared with the naive full
// scan byte for byte, at 1, 2 and 3 threads.
TEST(StereoMatch, MatchesNaiveFullScanOnRandomKeypoints) {
  for (std::uint64_t seed : {21u, 22u, 23u}) {
    const std::vector<int> shifts = {6, 5, 4};
    const StereoScene scene = make_scene(160, 96, shifts, seed, 6);
    const int levels = 3;
    std::uint64_t state = seed * 7919;
    std::vector<Keypoint> lk, rk;
    std::vector<Descriptor> ld, rd;
    auto random_kp = [&](int level) {
      const auto& size = scene.sizes[static_cast<std::size_t>(level)];
      return kp(random_below(state, size.first), random_below(state, size.second), level);
    };
    for (int i = 0; i < 200; ++i) {
      const int n = random_below(state, levels);
      lk.push_back(random_kp(n));
      ld.push_back(random_descriptor(state));
      if (random_below(state, 4) == 0) continue;
      const int m = std::clamp(n + random_below(state, 3) - 1, 0, levels - 1);
      const double to_m = std::pow(kScale, n - m);
      const auto& size = scene.sizes[static_cast<std::size_t>(m)];
      const int x =
          std::clamp(static_cast<int>(std::lround((lk.back().x - shifts[static_cast<std::size_t>(n)]) * to_m)) +
                         random_below(state, 7) - 3,
                     0, size.first - 1);
      const int y = std::clamp(static_cast<int>(std::lround(lk.back().y * to_m)) + random_below(state, 3) - 1, 0,
                               size.second - 1);
      Descriptor d = ld.back();
      for (int f = random_below(state, 100); f > 0; --f) {
        const int bit = random_below(state, 256);
        d.bytes[static_cast<std::size_t>(bit / 8)] ^= static_cast<std::uint8_t>(1u << (bit % 8));
      }
      rk.push_back(kp(x, y, m));
      rd.push_back(d);
      if (random_below(state, 4) == 0) {  // an exact duplicate: equal distance, higher index
        rk.push_back(rk.back());
        rd.push_back(rd.back());
      }
    }
    for (int i = 0; i < 60; ++i) {
      rk.push_back(random_kp(random_below(state, levels)));
      rd.push_back(random_descriptor(state));
    }
    for (std::size_t i = rk.size() - 1; i > 0; --i) {  // shuffle so that index order != row order
      const auto j = static_cast<std::size_t>(random_below(state, static_cast<int>(i) + 1));
      std::swap(rk[i], rk[j]);
      std::swap(rd[i], rd[j]);
    }

    const NaiveStereo want = naive_stereo(scene, lk, ld, rk, rd);
    int matched = 0;
    for (const auto& m : want.matches) matched += m.right_index >= 0 ? 1 : 0;
    EXPECT_GE(matched, 30) << "seed " << seed << ": too few matches to test much";
    EXPECT_GE(want.rejected_by_median, 1) << "seed " << seed << ": the median cut was not exercised";
    for (int threads : {1, 2, 3}) {
      CpuBackend backend(threads);
      expect_same_bytes(run_stereo(backend, scene, lk, ld, rk, rd), want.matches,
                        ("stereo, seed " + std::to_string(seed) + ", threads " + std::to_string(threads)).c_str());
    }
  }
}

// ---- projection_match ------------------------------------------------------------------------

std::vector<ProjectionResult> run_projection(CpuBackend& backend, const std::vector<Keypoint>& kps,
                                             const std::vector<Descriptor>& kd,
                                             const std::vector<ProjectionQuery>& queries,
                                             const std::vector<Descriptor>& qd,
                                             const std::vector<std::int32_t>& scales) {
  const DeviceKeypoints k = upload_keypoints(backend, kps, kd);
  auto q = backend.allocate(queries.size() * sizeof(ProjectionQuery));
  auto d = backend.allocate(qd.size() * sizeof(Descriptor));
  auto results = backend.allocate(queries.size() * sizeof(ProjectionResult));
  backend.upload(*q, 0, queries.data(), queries.size() * sizeof(ProjectionQuery));
  backend.upload(*d, 0, qd.data(), qd.size() * sizeof(Descriptor));
  backend.fill(*results, 0, results->size_bytes(), 0x7F);
  backend.projection_match(k.list(), *k.descriptors, *q, *d, static_cast<int>(queries.size()), scales, *results);
  std::vector<ProjectionResult> out(queries.size());
  backend.download(*results, 0, out.data(), out.size() * sizeof(ProjectionResult));
  return out;
}

ProjectionQuery query(int u_q8, int v_q8, int radius_q8, int min_level, int max_level) {
  ProjectionQuery q;
  q.u_q8 = u_q8;
  q.v_q8 = v_q8;
  q.radius_q8 = radius_q8;
  q.min_level = static_cast<std::uint8_t>(min_level);
  q.max_level = static_cast<std::uint8_t>(max_level);
  return q;
}

struct ProjectionFixture : ::testing::Test {
  CpuBackend backend{2};
  std::vector<std::int32_t> scales = build_level_scales_q16(4, kScale);
  Descriptor base = [] {
    std::uint64_t s = 31;
    return random_descriptor(s);
  }();
  /// One query with descriptor `base` against keypoints at the given distances from it.
  ProjectionResult one(const std::vector<Keypoint>& kps, const std::vector<int>& distances, const ProjectionQuery& q) {
    std::vector<Descriptor> kd;
    for (int d : distances) kd.push_back(flip_first_bits(base, d));
    return run_projection(backend, kps, kd, {q}, {base}, scales)[0];
  }
};

// Keypoint (100, 50) at level 0 sits at (25600, 12800) q8; the window is a closed square.
TEST_F(ProjectionFixture, WindowBoundsAreInclusive) {
  const std::vector<Keypoint> k = {kp(100, 50, 0)};
  EXPECT_EQ(one(k, {4}, query(25600 + 512, 12800, 512, 0, 0)).best_index, 0);
  EXPECT_EQ(one(k, {4}, query(25600 + 512, 12800, 511, 0, 0)).best_index, -1);
  EXPECT_EQ(one(k, {4}, query(25600 - 512, 12800, 512, 0, 0)).best_index, 0);
  EXPECT_EQ(one(k, {4}, query(25600 - 513, 12800, 512, 0, 0)).best_index, -1);
  EXPECT_EQ(one(k, {4}, query(25600, 12800 + 300, 300, 0, 0)).best_index, 0);
  EXPECT_EQ(one(k, {4}, query(25600, 12800 - 301, 300, 0, 0)).best_index, -1);
  EXPECT_EQ(one(k, {4}, query(25600, 12800, 0, 0, 0)).best_distance, 4);  // radius 0: the exact point
  // Level 1 (52, 50): u = 15974 (see StereoMath.Level0PositionRoundsToNearestQ8), v = 15360.
  EXPECT_EQ(one({kp(52, 50, 1)}, {4}, query(15974 + 100, 15360, 100, 0, 3)).best_index, 0);
  EXPECT_EQ(one({kp(52, 50, 1)}, {4}, query(15974 + 101, 15360, 100, 0, 3)).best_index, -1);
}

TEST_F(ProjectionFixture, LevelRangeIsInclusive) {
  const std::vector<Keypoint> k = {kp(50, 50, 2)};  // u = v = (50 * 94372 + 128) >> 8 = 18432
  EXPECT_EQ(one(k, {9}, query(18432, 18432, 256, 2, 2)).best_index, 0);
  EXPECT_EQ(one(k, {9}, query(18432, 18432, 256, 0, 2)).best_index, 0);
  EXPECT_EQ(one(k, {9}, query(18432, 18432, 256, 2, 3)).best_index, 0);
  EXPECT_EQ(one(k, {9}, query(18432, 18432, 256, 0, 1)).best_index, -1);
  EXPECT_EQ(one(k, {9}, query(18432, 18432, 256, 3, 3)).best_index, -1);
  EXPECT_EQ(one(k, {9}, query(18432, 18432, 256, 3, 1)).best_index, -1);  // empty range
}

TEST_F(ProjectionFixture, BestTiesGoToLowerIndexAndSecondIsTheRunnerUp) {
  const std::vector<Keypoint> k = {kp(100, 50, 0), kp(101, 50, 0), kp(99, 51, 0)};
  const ProjectionQuery q = query(25600, 12800, 1024, 0, 0);
  ProjectionResult r = one(k, {7, 3, 5}, q);
  EXPECT_EQ(r.best_index, 1);
  EXPECT_EQ(r.best_distance, 3);
  EXPECT_EQ(r.second_distance, 5);
  r = one(k, {6, 9, 6}, q);  // a tie: lower index best, the other one is second
  EXPECT_EQ(r.best_index, 0);
  EXPECT_EQ(r.best_distance, 6);
  EXPECT_EQ(r.second_distance, 6);
  r = one(k, {9, 2, 2}, q);
  EXPECT_EQ(r.best_index, 1);
  EXPECT_EQ(r.second_distance, 2);
  EXPECT_EQ(r.reserved, 0);
}

TEST_F(ProjectionFixture, EmptyWindowGivesMinusOneAnd256) {
  const ProjectionResult none = one({kp(10, 10, 0)}, {0}, query(25600, 12800, 256, 0, 3));
  EXPECT_EQ(none.best_index, -1);
  EXPECT_EQ(none.best_distance, 256);
  EXPECT_EQ(none.second_distance, 256);
  EXPECT_EQ(none.reserved, 0);
  // A single candidate at the largest distance is still the best; no second.
  const ProjectionResult far = one({kp(100, 50, 0)}, {256}, query(25600, 12800, 0, 0, 0));
  EXPECT_EQ(far.best_index, 0);
  EXPECT_EQ(far.best_distance, 256);
  EXPECT_EQ(far.second_distance, 256);
  EXPECT_TRUE(run_projection(backend, {}, {}, {}, {}, scales).empty());
}

// Keypoints on 4 levels with descriptors drawn near 6 prototypes (many equal distances), queries
// with random windows and level ranges; compared with a naive scan byte for byte.
TEST_F(ProjectionFixture, MatchesNaiveFullScanOnRandomKeypoints) {
  std::uint64_t state = 77;
  std::vector<Descriptor> prototypes;
  for (int i = 0; i < 6; ++i) prototypes.push_back(random_descriptor(state));
  auto near_prototype = [&] {
    return flip_first_bits(prototypes[static_cast<std::size_t>(random_below(state, 6))], random_below(state, 4));
  };
  std::vector<Keypoint> kps;
  std::vector<Descriptor> kd;
  for (int i = 0; i < 400; ++i) {
    const int level = random_below(state, 4);
    const double s = std::pow(kScale, level);
    kps.push_back(
        kp(random_below(state, static_cast<int>(320 / s)), random_below(state, static_cast<int>(240 / s)), level));
    kd.push_back(near_prototype());
  }
  std::vector<ProjectionQuery> queries;
  std::vector<Descriptor> qd;
  for (int i = 0; i < 300; ++i) {
    const int lo = random_below(state, 4), hi = random_below(state, 4);
    queries.push_back(
        query(random_below(state, 320 * 256), random_below(state, 240 * 256), random_below(state, 40 * 256), lo, hi));
    qd.push_back(near_prototype());
  }
  const auto want = naive_projection(kps, kd, queries, qd, scales);
  int found = 0, tied = 0;
  for (const auto& r : want) {
    found += r.best_index >= 0 ? 1 : 0;
    tied += r.best_index >= 0 && r.second_distance == r.best_distance ? 1 : 0;
  }
  EXPECT_GE(found, 50);
  EXPECT_GE(tied, 5);
  for (int threads : {1, 3}) {
    CpuBackend b(threads);
    expect_same_bytes(run_projection(b, kps, kd, queries, qd, scales), want, "projection");
  }
}

// ---- The whole frontend -----------------------------------------------------------------------

// A textured pair whose left image is the right one shifted by 8 px, through the real pipeline.
// Level-0 left keypoints see an exact copy of their right neighbourhood, so most of their
// disparities are within half a pixel of 8 px; higher levels are resampled and only counted.
TEST(StereoMatch, FrontendRecoversShiftOfTexturedPair) {
  constexpr int kShift = 8;
  const Image right = test::textured_image(320, 240, 7);
  const Image left = test::shifted_right(right, kShift);
  CpuBackend backend(2);
  StereoFeatures f;
  try {
    Frontend frontend(backend, FrontendSettings{}, 320, 240);
    f = frontend.detect_stereo(left.view(), right.view());
  } catch (const std::exception& e) {
    if (std::string(e.what()).find("not implemented") != std::string::npos) GTEST_SKIP() << e.what();
    throw;
  }
  ASSERT_EQ(f.matches.size(), f.left.keypoints.size());
  ASSERT_GE(f.left.keypoints.size(), 50u);
  int level0 = 0, level0_close = 0;
  for (std::size_t i = 0; i < f.matches.size(); ++i) {
    const StereoMatch& m = f.matches[i];
    if (m.right_index < 0) {
      EXPECT_EQ(m.disparity_q8, -1);
      continue;
    }
    ASSERT_LT(static_cast<std::size_t>(m.right_index), f.right.keypoints.size());
    EXPECT_LE(std::abs(f.right.keypoints[static_cast<std::size_t>(m.right_index)].level - f.left.keypoints[i].level),
              1);
    if (f.left.keypoints[i].level != 0) continue;
    ++level0;
    level0_close += std::abs(m.disparity_q8 - kShift * 256) <= 128 ? 1 : 0;
  }
  EXPECT_GE(f.num_matches() * 2, static_cast<int>(f.left.keypoints.size()));
  EXPECT_GE(level0, 20);
  EXPECT_GE(level0_close * 10, level0 * 9);
}

}  // namespace
}  // namespace porta
