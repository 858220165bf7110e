// One descriptor against many: the brute-force inner loop of keyframe-to-keyframe matching
// (match_by_descriptor: loop verification, relocalisation), private to porta_slam.
//
// The candidates' descriptors are laid out as four planes of 64-bit words (word w of candidate k
// at w * n + k), so that the distances to all of them are one loop over contiguous words that the
// compiler vectorises; on x86-64 CPUs with AVX-512 VPOPCNTDQ (Ice Lake and later Xeons, AMD Zen 4)
// a copy of that loop compiled for it counts eight words' bits per instruction (3.6x the portable
// loop and 6.0x the scan through indices before it, on the 2-core machine; docs/BENCHMARKS.md,
// "Descriptor matching on planes of words"). The nearest candidate
// and the second distance are then the ones a sequential scan finds: the first candidate at the
// smallest distance, and the smallest distance of the others.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "porta/keypoint.hpp"

namespace porta::slam::detail {

/// The nearest candidate of one query: its place among the candidates (-1: there are none), its
/// distance and the second smallest distance (257 where there is no such candidate).
struct Nearest {
  int index = -1;
  int best = 257;
  int second = 257;
};

class DescriptorPlanes {
 public:
  /// The candidates descriptors[which[0]], descriptors[which[1]], ... in that order.
  DescriptorPlanes(const std::vector<Descriptor>& descriptors, const std::vector<int>& which);

  std::size_t size() const { return n_; }

  /// The Hamming distance of `query` to every candidate, into out[0 .. size()). `vector_popcount`
  /// false takes the portable loop even where the CPU counts bits in vectors (tests, benchmarks).
  void distances(const Descriptor& query, std::uint16_t* out, bool vector_popcount = true) const;

  /// The nearest candidate as a sequential scan with strict comparisons finds it; `scratch` holds
  /// the distances (resized here; pass the same vector for every query).
  Nearest nearest(const Descriptor& query, std::vector<std::uint16_t>& scratch, bool vector_popcount = true) const;

 private:
  std::size_t n_ = 0;
  std::vector<std::uint64_t> words_;  // 4 planes of n_ words
};

/// Whether this CPU has the vector bit count the distances use (false off x86-64 and GCC).
bool has_vector_popcount();

}  // namespace porta::slam::detail
