// One descriptor against many; see descriptor_scan.hpp.
#include "descriptor_scan.hpp"

#include <algorithm>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
// The same loops compiled for AVX-512 with VPOPCNTDQ; called only where the CPU has it.
#define PORTA_VECTOR_POPCOUNT 1
#define PORTA_VECTOR_POPCOUNT_TARGET __attribute__((target("avx512f,avx512bw,avx512vl,avx512vpopcntdq")))
#else
#define PORTA_VECTOR_POPCOUNT 0
#endif

namespace porta::slam::detail {
namespace {

constexpr std::uint16_t kNone = 257;  // above any distance of 256-bit descriptors

/// out[k] = popcount(q ^ candidate k), over the four planes of n words.
[[gnu::always_inline]] inline void distance_loop(const std::uint64_t* __restrict words, std::size_t n,
                                                 const std::uint64_t (&q)[4], std::uint16_t* __restrict out) {
  const std::uint64_t* w0 = words;
  const std::uint64_t* w1 = words + n;
  const std::uint64_t* w2 = words + 2 * n;
  const std::uint64_t* w3 = words + 3 * n;
  const std::uint64_t q0 = q[0], q1 = q[1], q2 = q[2], q3 = q[3];
  for (std::size_t k = 0; k < n; ++k) {
    out[k] = static_cast<std::uint16_t>(__builtin_popcountll(q0 ^ w0[k]) + __builtin_popcountll(q1 ^ w1[k]) +
                                        __builtin_popcountll(q2 ^ w2[k]) + __builtin_popcountll(q3 ^ w3[k]));
  }
}

[[gnu::always_inline]] inline std::uint16_t min_loop(const std::uint16_t* d, std::size_t n) {
  std::uint16_t m = kNone;
  for (std::size_t k = 0; k < n; ++k) m = d[k] < m ? d[k] : m;
  return m;
}

void distances_portable(const std::uint64_t* words, std::size_t n, const std::uint64_t (&q)[4], std::uint16_t* out) {
  distance_loop(words, n, q, out);
}
std::uint16_t min_portable(const std::uint16_t* d, std::size_t n) { return min_loop(d, n); }

#if PORTA_VECTOR_POPCOUNT
PORTA_VECTOR_POPCOUNT_TARGET void distances_vector(const std::uint64_t* words, std::size_t n,
                                                   const std::uint64_t (&q)[4], std::uint16_t* out) {
  distance_loop(words, n, q, out);
}
PORTA_VECTOR_POPCOUNT_TARGET std::uint16_t min_vector(const std::uint16_t* d, std::size_t n) {
  return min_loop(d, n);
}
#endif

std::uint16_t min_of(const std::uint16_t* d, std::size_t n, bool vector_popcount) {
#if PORTA_VECTOR_POPCOUNT
  if (vector_popcount && has_vector_popcount()) return min_vector(d, n);
#else
  (void)vector_popcount;
#endif
  return min_portable(d, n);
}

}  // namespace

bool has_vector_popcount() {
#if PORTA_VECTOR_POPCOUNT
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512vpopcntdq");
  return has;
#else
  return false;
#endif
}

DescriptorPlanes::DescriptorPlanes(const std::vector<Descriptor>& descriptors, const std::vector<int>& which)
    : n_(which.size()), words_(4 * which.size()) {
  for (std::size_t k = 0; k < n_; ++k) {
    std::uint64_t w[4];
    std::memcpy(w, descriptors[static_cast<std::size_t>(which[k])].bytes.data(), sizeof(w));
    for (std::size_t p = 0; p < 4; ++p) words_[p * n_ + k] = w[p];
  }
}

void DescriptorPlanes::distances(const Descriptor& query, std::uint16_t* out, bool vector_popcount) const {
  std::uint64_t q[4];
  std::memcpy(q, query.bytes.data(), sizeof(q));
#if PORTA_VECTOR_POPCOUNT
  if (vector_popcount && has_vector_popcount()) {
    distances_vector(words_.data(), n_, q, out);
    return;
  }
#else
  (void)vector_popcount;
#endif
  distances_portable(words_.data(), n_, q, out);
}

Nearest DescriptorPlanes::nearest(const Descriptor& query, std::vector<std::uint16_t>& scratch,
                                  bool vector_popcount) const {
  Nearest result;
  if (n_ == 0) return result;
  scratch.resize(n_);
  const std::uint16_t* d = scratch.data();
  distances(query, scratch.data(), vector_popcount);
  const std::uint16_t best = min_of(d, n_, vector_popcount);
  std::size_t k = 0;
  while (d[k] != best) ++k;  // the first at the smallest distance: a strict `<` scan keeps it
  result.index = static_cast<int>(k);
  result.best = best;
  // The second distance of a scan that moves the best down is the smallest of all the others.
  result.second = std::min(min_of(d, k, vector_popcount), min_of(d + k + 1, n_ - k - 1, vector_popcount));
  return result;
}

}  // namespace porta::slam::detail
