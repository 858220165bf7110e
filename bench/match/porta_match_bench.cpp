// porta_match_bench: brute-force descriptor matching (match_by_descriptor: loop verification and
// relocalisation), the scan through the candidates' indices it replaced against the planes of
// slam/map/descriptor_scan.hpp with the portable and the vector bit count (Google Benchmark;
// docs/BENCHMARKS.md, "Descriptor matching").
//
//   porta_match_bench [--benchmark_repetitions=N ...]
//
// Sizes: 1 000 queries against 1 000 candidates, about a keyframe's features with map points.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "porta/slam/feature_matching.hpp"
#include "porta/slam/map.hpp"
#include "slam/map/descriptor_scan.hpp"

namespace {

using porta::Descriptor;

std::vector<Descriptor> random_descriptors(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Descriptor> out(n);
  for (Descriptor& d : out) {
    for (std::uint8_t& b : d.bytes) b = static_cast<std::uint8_t>(rng());
  }
  return out;
}

std::vector<int> every_index(std::size_t n) {
  std::vector<int> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<int>(i);
  return out;
}

/// The scan before the planes: each candidate through its index, one popcount per word.
void BM_NearestThroughIndices(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  const std::vector<Descriptor> queries = random_descriptors(n, 1), candidates = random_descriptors(n, 2);
  const std::vector<int> which = every_index(n);
  for (auto _ : state) {
    for (const Descriptor& q : queries) {
      int best = 257, second = 257, best_j = -1;
      for (const int j : which) {
        const int d = porta::slam::hamming_distance(q, candidates[static_cast<std::size_t>(j)]);
        if (d < best) {
          second = best;
          best = d;
          best_j = j;
        } else if (d < second) {
          second = d;
        }
      }
      benchmark::DoNotOptimize(best_j);
      benchmark::DoNotOptimize(second);
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n * n));
}
BENCHMARK(BM_NearestThroughIndices)->Arg(1000)->Unit(benchmark::kMicrosecond);

/// The planes: arg 1 = 0 the portable loop, 1 the vector bit count where the CPU has it.
void BM_NearestPlanes(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  const bool vector_popcount = state.range(1) != 0;
  if (vector_popcount && !porta::slam::detail::has_vector_popcount()) {
    state.SkipWithError("this CPU has no AVX-512 VPOPCNTDQ");
    return;
  }
  const std::vector<Descriptor> queries = random_descriptors(n, 1), candidates = random_descriptors(n, 2);
  const porta::slam::detail::DescriptorPlanes planes(candidates, every_index(n));
  std::vector<std::uint16_t> scratch;
  for (auto _ : state) {
    for (const Descriptor& q : queries) benchmark::DoNotOptimize(planes.nearest(q, scratch, vector_popcount));
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n * n));
}
BENCHMARK(BM_NearestPlanes)->Args({1000, 0})->Args({1000, 1})->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
