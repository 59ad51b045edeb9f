#pragma once
// The few vector operations the compositing kernels use, for three widths: 1 lane (portable C++), 4 lanes
// (SSE2, every x86-64 CPU) and 8 lanes (AVX2, compiled only where the including file enables it). A kernel
// written once against this interface is instantiated for each, and the caller picks the widest the CPU
// has at run time.
//
// Masks are float vectors whose lanes are all ones (true) or all zeros (false), as the compare
// instructions produce them. Every operation is the plain IEEE one, lane by lane and without fused
// multiply-adds, so a lane computes the same bits whatever the width.
#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace lrf::splat::simd {

struct Scalar {
  static constexpr int kWidth = 1;
  using F = float;
  using I = int32_t;
  static F as_float(I i) {
    F f;
    std::memcpy(&f, &i, sizeof(f));
    return f;
  }
  static I as_int(F f) {
    I i;
    std::memcpy(&i, &f, sizeof(i));
    return i;
  }
  static F mask(bool b) { return as_float(b ? -1 : 0); }

  static F zero() { return 0.f; }
  static F set1(float v) { return v; }
  static F load(const float* p) { return *p; }
  static void store(float* p, F v) { *p = v; }
  static F add(F a, F b) { return a + b; }
  static F sub(F a, F b) { return a - b; }
  static F mul(F a, F b) { return a * b; }
  static F div(F a, F b) { return a / b; }
  static F sqrt(F a) { return std::sqrt(a); }
  static F min(F a, F b) { return a < b ? a : b; }  // the minps / maxps rules (b when either is NaN)
  static F max(F a, F b) { return a > b ? a : b; }
  static F cmple(F a, F b) { return mask(a <= b); }
  static F cmpge(F a, F b) { return mask(a >= b); }
  static F cmplt(F a, F b) { return mask(a < b); }
  static F cmpgt(F a, F b) { return mask(a > b); }
  static F cmpneq(F a, F b) { return mask(a != b); }
  static F and_(F a, F b) { return as_float(as_int(a) & as_int(b)); }
  static F andnot(F m, F b) { return as_float(~as_int(m) & as_int(b)); }  // (not m) and b
  static int movemask(F m) { return as_int(m) < 0 ? 1 : 0; }
  static float hsum(F v) { return v; }

  static I set1i(int32_t v) { return v; }
  static I rampi() { return 0; }  // lane k holds k
  static I loadi(const int32_t* p) { return *p; }
  static void storei(int32_t* p, I v) { *p = v; }
  static I addi(I a, I b) { return a + b; }
  static I subi(I a, I b) { return a - b; }
  static I andi(I a, I b) { return a & b; }
  static I andnoti(I m, I b) { return ~m & b; }
  static I ori(I a, I b) { return a | b; }
  static I cmplti(I a, I b) { return a < b ? -1 : 0; }
  static I cmpgti(I a, I b) { return a > b ? -1 : 0; }
  static F to_float(I v) { return static_cast<float>(v); }
  // Out of range or NaN gives INT32_MIN, as cvttps does (and a plain cast would be undefined).
  static I truncate(F v) { return v > -2147483648.f && v < 2147483648.f ? static_cast<int32_t>(v) : INT32_MIN; }
  static I shift_left(I v, int bits) { return static_cast<int32_t>(static_cast<uint32_t>(v) << bits); }
  static I shift_right(I v, int bits) { return static_cast<int32_t>(static_cast<uint32_t>(v) >> bits); }
};

#if defined(__SSE2__)
struct Sse2 {
  static constexpr int kWidth = 4;
  using F = __m128;
  using I = __m128i;
  static F as_float(I i) { return _mm_castsi128_ps(i); }
  static I as_int(F f) { return _mm_castps_si128(f); }

  static F zero() { return _mm_setzero_ps(); }
  static F set1(float v) { return _mm_set1_ps(v); }
  static F load(const float* p) { return _mm_loadu_ps(p); }
  static void store(float* p, F v) { _mm_storeu_ps(p, v); }
  static F add(F a, F b) { return _mm_add_ps(a, b); }
  static F sub(F a, F b) { return _mm_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm_mul_ps(a, b); }
  static F div(F a, F b) { return _mm_div_ps(a, b); }
  static F sqrt(F a) { return _mm_sqrt_ps(a); }
  static F min(F a, F b) { return _mm_min_ps(a, b); }
  static F max(F a, F b) { return _mm_max_ps(a, b); }
  static F cmple(F a, F b) { return _mm_cmple_ps(a, b); }
  static F cmpge(F a, F b) { return _mm_cmpge_ps(a, b); }
  static F cmplt(F a, F b) { return _mm_cmplt_ps(a, b); }
  static F cmpgt(F a, F b) { return _mm_cmpgt_ps(a, b); }
  static F cmpneq(F a, F b) { return _mm_cmpneq_ps(a, b); }
  static F and_(F a, F b) { return _mm_and_ps(a, b); }
  static F andnot(F m, F b) { return _mm_andnot_ps(m, b); }
  static int movemask(F m) { return _mm_movemask_ps(m); }
  static float hsum(F v) {
    const F s = _mm_add_ps(v, _mm_movehl_ps(v, v));
    return _mm_cvtss_f32(_mm_add_ss(s, _mm_shuffle_ps(s, s, 1)));
  }

  static I set1i(int32_t v) { return _mm_set1_epi32(v); }
  static I rampi() { return _mm_setr_epi32(0, 1, 2, 3); }
  static I loadi(const int32_t* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }
  static void storei(int32_t* p, I v) { _mm_storeu_si128(reinterpret_cast<__m128i*>(p), v); }
  static I addi(I a, I b) { return _mm_add_epi32(a, b); }
  static I subi(I a, I b) { return _mm_sub_epi32(a, b); }
  static I andi(I a, I b) { return _mm_and_si128(a, b); }
  static I andnoti(I m, I b) { return _mm_andnot_si128(m, b); }
  static I ori(I a, I b) { return _mm_or_si128(a, b); }
  static I cmplti(I a, I b) { return _mm_cmplt_epi32(a, b); }
  static I cmpgti(I a, I b) { return _mm_cmpgt_epi32(a, b); }
  static F to_float(I v) { return _mm_cvtepi32_ps(v); }
  static I truncate(F v) { return _mm_cvttps_epi32(v); }
  static I shift_left(I v, int bits) { return _mm_slli_epi32(v, bits); }
  static I shift_right(I v, int bits) { return _mm_srli_epi32(v, bits); }

  // Two half vectors: lanes [0, 2) at lo, [2, 4) at hi (two rows of a tile at once).
  static F load_halves(const float* lo, const float* hi) {
    return _mm_castpd_ps(_mm_loadh_pd(_mm_load_sd(reinterpret_cast<const double*>(lo)),
                                      reinterpret_cast<const double*>(hi)));
  }
  static void store_halves(float* lo, float* hi, F v) {
    _mm_storel_pd(reinterpret_cast<double*>(lo), _mm_castps_pd(v));
    _mm_storeh_pd(reinterpret_cast<double*>(hi), _mm_castps_pd(v));
  }
  static I loadi_halves(const int32_t* lo, const int32_t* hi) {
    return as_int(load_halves(reinterpret_cast<const float*>(lo), reinterpret_cast<const float*>(hi)));
  }
  static void storei_halves(int32_t* lo, int32_t* hi, I v) {
    store_halves(reinterpret_cast<float*>(lo), reinterpret_cast<float*>(hi), as_float(v));
  }
  static F set1_halves(float lo, float hi) { return _mm_setr_ps(lo, lo, hi, hi); }
  static I ramp_halves() { return _mm_setr_epi32(0, 1, 0, 1); }
};
#endif

#if defined(__AVX2__)
struct Avx2 {
  static constexpr int kWidth = 8;
  using F = __m256;
  using I = __m256i;
  static F as_float(I i) { return _mm256_castsi256_ps(i); }
  static I as_int(F f) { return _mm256_castps_si256(f); }

  static F zero() { return _mm256_setzero_ps(); }
  static F set1(float v) { return _mm256_set1_ps(v); }
  static F load(const float* p) { return _mm256_loadu_ps(p); }
  static void store(float* p, F v) { _mm256_storeu_ps(p, v); }
  static F add(F a, F b) { return _mm256_add_ps(a, b); }
  static F sub(F a, F b) { return _mm256_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm256_mul_ps(a, b); }
  static F div(F a, F b) { return _mm256_div_ps(a, b); }
  static F sqrt(F a) { return _mm256_sqrt_ps(a); }
  static F min(F a, F b) { return _mm256_min_ps(a, b); }
  static F max(F a, F b) { return _mm256_max_ps(a, b); }
  static F cmple(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LE_OS); }
  static F cmpge(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GE_OS); }
  static F cmplt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_LT_OS); }
  static F cmpgt(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_GT_OS); }
  static F cmpneq(F a, F b) { return _mm256_cmp_ps(a, b, _CMP_NEQ_UQ); }
  static F and_(F a, F b) { return _mm256_and_ps(a, b); }
  static F andnot(F m, F b) { return _mm256_andnot_ps(m, b); }
  static int movemask(F m) { return _mm256_movemask_ps(m); }
  static float hsum(F v) {
    const __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    const __m128 t = _mm_add_ps(s, _mm_movehl_ps(s, s));
    return _mm_cvtss_f32(_mm_add_ss(t, _mm_shuffle_ps(t, t, 1)));
  }

  static I set1i(int32_t v) { return _mm256_set1_epi32(v); }
  static I rampi() { return _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7); }
  static I loadi(const int32_t* p) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)); }
  static void storei(int32_t* p, I v) { _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), v); }
  static I addi(I a, I b) { return _mm256_add_epi32(a, b); }
  static I subi(I a, I b) { return _mm256_sub_epi32(a, b); }
  static I andi(I a, I b) { return _mm256_and_si256(a, b); }
  static I andnoti(I m, I b) { return _mm256_andnot_si256(m, b); }
  static I ori(I a, I b) { return _mm256_or_si256(a, b); }
  static I cmplti(I a, I b) { return _mm256_cmpgt_epi32(b, a); }
  static I cmpgti(I a, I b) { return _mm256_cmpgt_epi32(a, b); }
  static F to_float(I v) { return _mm256_cvtepi32_ps(v); }
  static I truncate(F v) { return _mm256_cvttps_epi32(v); }
  static I shift_left(I v, int bits) { return _mm256_slli_epi32(v, bits); }
  static I shift_right(I v, int bits) { return _mm256_srli_epi32(v, bits); }

  // Two half vectors: lanes [0, 4) at lo, [4, 8) at hi (two rows of a tile at once).
  static F load_halves(const float* lo, const float* hi) { return _mm256_loadu2_m128(hi, lo); }
  static void store_halves(float* lo, float* hi, F v) { _mm256_storeu2_m128(hi, lo, v); }
  static I loadi_halves(const int32_t* lo, const int32_t* hi) {
    return _mm256_loadu2_m128i(reinterpret_cast<const __m128i*>(hi), reinterpret_cast<const __m128i*>(lo));
  }
  static void storei_halves(int32_t* lo, int32_t* hi, I v) {
    _mm256_storeu2_m128i(reinterpret_cast<__m128i*>(hi), reinterpret_cast<__m128i*>(lo), v);
  }
  static F set1_halves(float lo, float hi) { return _mm256_setr_m128(_mm_set1_ps(lo), _mm_set1_ps(hi)); }
  static I ramp_halves() { return _mm256_setr_epi32(0, 1, 2, 3, 0, 1, 2, 3); }
};
#endif

// e^x = 2^n·e^r with r = x − n·ln2 (ln2 split in two for accuracy), e^r from a degree-6 polynomial
// (Cephes-style, ~2 ulp) and 2^n through the exponent bits; n must lie in [−126, 127].
template <class V>
typename V::F exp_reduced(typename V::F x, typename V::I n) {
  using F = typename V::F;
  const F fn = V::to_float(n);
  const F r = V::add(V::sub(x, V::mul(fn, V::set1(0.693359375f))), V::mul(fn, V::set1(2.12194440e-4f)));
  F p = V::set1(1.9875691500e-4f);
  p = V::add(V::mul(p, r), V::set1(1.3981999507e-3f));
  p = V::add(V::mul(p, r), V::set1(8.3334519073e-3f));
  p = V::add(V::mul(p, r), V::set1(4.1665795894e-2f));
  p = V::add(V::mul(p, r), V::set1(1.6666665459e-1f));
  p = V::add(V::mul(p, r), V::set1(5.0000001201e-1f));
  p = V::add(V::add(V::mul(V::mul(p, r), r), r), V::set1(1.f));
  return V::mul(p, V::as_float(V::shift_left(V::addi(n, V::set1i(127)), 23)));
}

// e^x for x <= 0 (flushes to ~1.6e-38 below −87), in a fixed order of plain operations so that every width
// gives the same bits.
template <class V>
typename V::F exp_nonpositive(typename V::F x) {
  x = V::max(x, V::set1(-87.f));
  // Truncation of x·log2(e) − 0.5 rounds to nearest for x <= 0.
  return exp_reduced<V>(x, V::truncate(V::sub(V::mul(x, V::set1(1.44269504088896341f)), V::set1(0.5f))));
}

// e^x for any x, clamped to [−87, 88] first (e^88 ~ 1.7e38 is still finite).
template <class V>
typename V::F exp_any(typename V::F x) {
  using F = typename V::F;
  x = V::min(V::max(x, V::set1(-87.f)), V::set1(88.f));
  const F t = V::mul(x, V::set1(1.44269504088896341f));
  // Round to nearest: truncate t + ½ above zero, t − ½ below.
  const F half = V::add(V::and_(V::cmplt(t, V::zero()), V::set1(-1.f)), V::set1(0.5f));
  return exp_reduced<V>(x, V::truncate(V::add(t, half)));
}

// Natural logarithm of a positive, normal x (Cephes-style: x = m·2^e with m in [√½, √2), degree-8
// polynomial in m − 1; ~2 ulp). Zero, negative, subnormal, infinite and NaN inputs give garbage.
template <class V>
typename V::F log_positive(typename V::F x) {
  using F = typename V::F;
  using I = typename V::I;
  const I bits = V::as_int(x);
  F e = V::to_float(V::subi(V::shift_right(bits, 23), V::set1i(126)));
  // m in [0.5, 1): x's mantissa with the exponent of 0.5.
  F m = V::as_float(V::ori(V::andi(bits, V::set1i(0x007fffff)), V::set1i(0x3f000000)));
  const F one = V::set1(1.f);
  const F small = V::cmplt(m, V::set1(0.707106781186547524f));
  e = V::sub(e, V::and_(small, one));
  m = V::sub(V::add(m, V::and_(small, m)), one);  // 2m − 1 below √½, else m − 1
  const F z = V::mul(m, m);
  F y = V::set1(7.0376836292e-2f);
  y = V::add(V::mul(y, m), V::set1(-1.1514610310e-1f));
  y = V::add(V::mul(y, m), V::set1(1.1676998740e-1f));
  y = V::add(V::mul(y, m), V::set1(-1.2420140846e-1f));
  y = V::add(V::mul(y, m), V::set1(1.4249322787e-1f));
  y = V::add(V::mul(y, m), V::set1(-1.6668057665e-1f));
  y = V::add(V::mul(y, m), V::set1(2.0000714765e-1f));
  y = V::add(V::mul(y, m), V::set1(-2.4999993993e-1f));
  y = V::add(V::mul(y, m), V::set1(3.3333331174e-1f));
  y = V::mul(V::mul(y, m), z);
  y = V::add(y, V::mul(e, V::set1(-2.12194440e-4f)));
  y = V::sub(y, V::mul(z, V::set1(0.5f)));
  return V::add(V::add(m, y), V::mul(e, V::set1(0.693359375f)));
}

}  // namespace lrf::splat::simd
