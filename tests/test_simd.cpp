// The vector math of simd.h that the projection and compositing kernels share: accuracy against libm in
// double, and the same bits at every width this file can build (1 lane, and 4 with SSE2; the AVX2 build is
// covered through the kernels by Rasterizer.EveryVectorWidthGivesTheSameResult).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "lrf/splat/raster/simd.h"

namespace {

using lrf::splat::simd::Scalar;

// Inputs spread over [lo, hi] plus its ends.
std::vector<float> grid(float lo, float hi, int n) {
  std::vector<float> x;
  for (int i = 0; i <= n; ++i) x.push_back(lo + (hi - lo) * static_cast<float>(i) / static_cast<float>(n));
  return x;
}

uint32_t bits(float v) {
  uint32_t b;
  std::memcpy(&b, &v, sizeof(b));
  return b;
}

// A float has a 24-bit significand: one unit in the last place is 2^-23 of the value at most. The
// polynomials are accurate to about 2 ulp; 4 ulp (4.8e-7 relative) leaves room for the range reduction and
// would still catch a wrong coefficient (errors of 1e-5 and more).
constexpr double kRelTol = 4.0 / (1 << 23);

TEST(Simd, ExponentialsMatchLibm) {
  for (float x : grid(-87.f, 88.f, 20011)) {
    const double want = std::exp(static_cast<double>(x));
    EXPECT_NEAR(lrf::splat::simd::exp_any<Scalar>(x) / want, 1.0, kRelTol) << x;
    if (x <= 0) {
      EXPECT_NEAR(lrf::splat::simd::exp_nonpositive<Scalar>(x) / want, 1.0, kRelTol) << x;
    }
  }
  // Clamped outside [−87, 88]: finite and positive, never inf or 0.
  EXPECT_FLOAT_EQ(lrf::splat::simd::exp_any<Scalar>(200.f), lrf::splat::simd::exp_any<Scalar>(88.f));
  EXPECT_GT(lrf::splat::simd::exp_any<Scalar>(-1000.f), 0.f);
  EXPECT_TRUE(std::isfinite(lrf::splat::simd::exp_any<Scalar>(1e30f)));
}

TEST(Simd, LogarithmMatchesLibm) {
  std::vector<float> xs = grid(1e-30f, 1e-20f, 1000);
  for (float x : grid(0.01f, 3.f, 20011)) xs.push_back(x);
  for (float x : grid(1.f, 1e6f, 20011)) xs.push_back(x);
  xs.push_back(1.f + 1.2e-7f);
  xs.push_back(0.70710677f);
  for (float x : xs) {
    const double want = std::log(static_cast<double>(x));
    // Near x = 1 the result itself goes to 0: there the error is bounded in absolute terms, by one ulp of
    // the argument (which is all that is known about ln x once x is rounded to float).
    EXPECT_NEAR(lrf::splat::simd::log_positive<Scalar>(x), want, std::abs(want) * kRelTol + 1.2e-7) << x;
  }
  EXPECT_EQ(lrf::splat::simd::log_positive<Scalar>(1.f), 0.f);
}

TEST(Simd, ScalarTruncationMatchesTheInstruction) {
  EXPECT_EQ(Scalar::truncate(-2.7f), -2);
  EXPECT_EQ(Scalar::truncate(3e9f), INT32_MIN);
  EXPECT_EQ(Scalar::truncate(-3e9f), INT32_MIN);
  EXPECT_EQ(Scalar::truncate(std::nanf("")), INT32_MIN);
}

#if defined(__SSE2__)
using lrf::splat::simd::Sse2;

template <typename Fn4, typename Fn1>
void expect_same_bits(const std::vector<float>& xs, Fn4 vector_fn, Fn1 scalar_fn) {
  for (size_t i = 0; i + 4 <= xs.size(); i += 4) {
    alignas(16) float out[4];
    Sse2::store(out, vector_fn(Sse2::load(&xs[i])));
    for (int k = 0; k < 4; ++k) EXPECT_EQ(bits(out[k]), bits(scalar_fn(xs[i + k]))) << xs[i + k];
  }
}

TEST(Simd, FourLanesGiveTheBitsOfOne) {
  std::vector<float> xs = grid(-100.f, 100.f, 4003);
  expect_same_bits(xs, lrf::splat::simd::exp_any<Sse2>, lrf::splat::simd::exp_any<Scalar>);
  std::vector<float> neg = grid(-100.f, 0.f, 4003);
  expect_same_bits(neg, lrf::splat::simd::exp_nonpositive<Sse2>, lrf::splat::simd::exp_nonpositive<Scalar>);
  std::vector<float> pos = grid(1e-3f, 1e4f, 4003);
  expect_same_bits(pos, lrf::splat::simd::log_positive<Sse2>, lrf::splat::simd::log_positive<Scalar>);
  // volatile: the compiler would fold the conversion of constants, and not as the instruction does.
  volatile float odd[4] = {3e9f, -3e9f, std::nanf(""), -2.7f};
  alignas(16) int32_t truncated[4];
  Sse2::storei(truncated, Sse2::truncate(_mm_setr_ps(odd[0], odd[1], odd[2], odd[3])));
  for (int k = 0; k < 4; ++k) EXPECT_EQ(truncated[k], Scalar::truncate(odd[k])) << odd[k];
}
#endif

}  // namespace
