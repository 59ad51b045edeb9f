#pragma once
// AVX-512 loads and stores of bf16 channel vectors, and the target attribute of the project's own bf16
// kernels (the Winograd ones and the narrow one). Each function is compiled for AVX512_BF16 on its own, so
// the build stays generic; callers check that the CPU has it (WinogradConv3x3::available(),
// NarrowConv3x3::available()) before running them.
#include <cstdint>

#if defined(__x86_64__)
#include <immintrin.h>

#define LRF_AVX512_BF16 __attribute__((target("avx512f,avx512bw,avx512vl,avx512dq,avx512bf16")))

namespace lrf::bf16_vectors {

constexpr __mmask16 kAll = 0xFFFF;

// 16 bf16 values as float32.
LRF_AVX512_BF16 inline __m512 load16(const uint16_t* p) {
  const __m256i h = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
  // The maskz forms: GCC 12's unmasked ones read an uninitialised register and warn about it.
  return _mm512_castsi512_ps(_mm512_maskz_slli_epi32(kAll, _mm512_maskz_cvtepu16_epi32(kAll, h), 16));
}

// The even (0, 2, .., 30) or the odd channels of 32 bf16 ones loaded as one vector, as float32: a bf16 is
// the high half of a float32, so each is one instruction, no shuffles. The Winograd kernels keep their
// transformed channels in this order, evens first.
LRF_AVX512_BF16 inline __m512 even_half(__m512i v) { return _mm512_castsi512_ps(_mm512_maskz_slli_epi32(kAll, v, 16)); }
LRF_AVX512_BF16 inline __m512 odd_half(__m512i v) {
  return _mm512_castsi512_ps(_mm512_maskz_and_epi32(kAll, v, _mm512_set1_epi32(static_cast<int>(0xFFFF0000u))));
}

// 32 channels as float32: [0] the even ones, [1] the odd ones.
LRF_AVX512_BF16 inline void load32_split(const uint16_t* p, __m512 out[2]) {
  const __m512i v = _mm512_loadu_si512(p);
  out[0] = even_half(v);
  out[1] = odd_half(v);
}

// One of load32_split's halves: 0 the even channels, 1 the odd ones.
LRF_AVX512_BF16 inline __m512 load32_half(const uint16_t* p, int half) {
  const __m512i v = _mm512_loadu_si512(p);
  return half == 0 ? even_half(v) : odd_half(v);
}

// Rounds 2 x 16 floats to bf16 (nearest, ties to even) and stores them, `low` first.
LRF_AVX512_BF16 inline void store32(uint16_t* p, __m512 low, __m512 high) {
  _mm512_storeu_si512(p, reinterpret_cast<__m512i>(_mm512_cvtne2ps_pbh(high, low)));
}

// Rounds 16 floats to bf16 (nearest, ties to even) and stores them.
LRF_AVX512_BF16 inline void store16(uint16_t* p, __m512 v) {
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), reinterpret_cast<__m256i>(_mm512_cvtneps_pbh(v)));
}

}  // namespace lrf::bf16_vectors
#endif
