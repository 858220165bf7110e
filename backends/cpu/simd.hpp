// Portable SIMD for the cpu backend's hot loops, without intrinsics: GCC/Clang vector extensions
// lower to SSE2/AVX2 on x86-64 and to NEON on aarch64 (Jetson), and PORTA_CPU_HOT adds AVX-512
// (x86-64-v4) and AVX2 clones of a function on x86-64 that the loader picks at run time where the
// CPU has them. The AVX-512 clone keeps the 32-byte vectors but has twice the registers and mask
// compares: 1242x375 stereo on one thread 12.3-12.9 -> 11.5-11.6 ms on the 2-core machine
// (rendered KITTI images, `portaslam bench --threads 1`, docs/BENCHMARKS.md).
//
// Rules for code that uses these types (so that every path gives the reference's bytes):
//  - integer lanes only, with the same formula as the scalar loop it replaces; the scalar loop
//    stays next to it for the tails and borders, and tests compare both against hand-worked
//    values and against the other backends;
//  - vectors live inside one function (no vector arguments across clones: the ABI differs);
//  - loads and stores go through load<V>() / store() (memcpy, any alignment).
#pragma once

#include <cstdint>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__) && !defined(PORTA_CPU_NO_CLONES)
/// AVX-512 and AVX2 clones and the baseline; the dynamic loader picks one once, at start-up.
#define PORTA_CPU_HOT __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define PORTA_CPU_HOT
#endif

// The helpers below pass vectors by value but are always inlined, so the ABI note GCC gives for
// 32-byte vectors without AVX (-Wpsabi) does not apply; backends/cpu/CMakeLists.txt turns it off.

namespace porta::cpu::simd {

/// 32 lanes of u8/i8, 16 of u16: one AVX2 register, two SSE2 or NEON registers.
using u8x32 = std::uint8_t __attribute__((vector_size(32)));
using i8x32 = std::int8_t __attribute__((vector_size(32)));
using u16x16 = std::uint16_t __attribute__((vector_size(32)));
/// Half-width companion for widening (u8x16 -> u16x16).
using u8x16 = std::uint8_t __attribute__((vector_size(16)));

template <typename V, typename T>
[[gnu::always_inline]] inline V load(const T* p) {
  V v;
  std::memcpy(&v, p, sizeof(V));
  return v;
}

template <typename T, typename V>
[[gnu::always_inline]] inline void store(T* p, const V& v) {
  std::memcpy(p, &v, sizeof(V));
}

/// Lanes of `v` widened (zero-extended) or narrowed (truncated) to the lane type of `To`.
template <typename To, typename From>
[[gnu::always_inline]] inline To convert(const From& v) {
  return __builtin_convertvector(v, To);
}

}  // namespace porta::cpu::simd
