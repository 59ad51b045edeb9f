// The one function that seeds every per-step random stream (core/seed_stream.h).
#include <set>

#include <gtest/gtest.h>

#include "lrf/core/seed_stream.h"

namespace {

using lrf::SeedStream;

TEST(SeedStream, StreamsStepsAndRunSeedsNeverShareASeed) {
  std::set<uint64_t> seen;
  size_t drawn = 0;
  for (uint64_t run : {0ull, 1ull, 2ull, 42ull})
    for (uint64_t stream = 1; stream <= 8; ++stream)
      for (uint64_t step = 0; step < 2000; ++step) {
        seen.insert(lrf::stream_seed(run, static_cast<SeedStream>(stream), step));
        ++drawn;
      }
  EXPECT_EQ(seen.size(), drawn);
}

TEST(SeedStream, NeighbouringStepsDifferInAboutHalfTheirBits) {
  // A generator seeded by nearly equal seeds can start nearly equal sequences; the finaliser must spread a
  // one-step change over the whole word: 32 of 64 bits on average for independent seeds, and the mean over
  // 1000 pairs then has a spread of about 0.13 bit, so +-1.5 fails only a mix that is biased.
  double bits = 0;
  for (uint64_t step = 0; step < 1000; ++step)
    bits += __builtin_popcountll(lrf::stream_seed(7, SeedStream::stage3_crops, step) ^
                                 lrf::stream_seed(7, SeedStream::stage3_crops, step + 1));
  EXPECT_NEAR(bits / 1000, 32, 1.5);
}

TEST(SeedStream, TheGaussianTrainersStreamsKeepTheirSequence) {
  // Written out as the trainer computed its view order and splits before the streams were gathered here:
  // fixed-seed Gaussian fits (RGB, latent, feature) must not change.
  auto earlier = [](uint64_t seed, uint64_t stream, uint64_t index) {
    uint64_t x = seed * 0x9E3779B97F4A7C15ull ^ (stream + 0x632BE59BD9B4E019ull) * 0xBF58476D1CE4E5B9ull ^ index;
    x ^= x >> 31;
    x *= 0x94D049BB133111EBull;
    x ^= x >> 29;
    return x;
  };
  for (uint64_t seed : {0ull, 3ull, 123456789ull})
    for (uint64_t index : {0ull, 1ull, 29999ull}) {
      EXPECT_EQ(lrf::stream_seed(seed, SeedStream::view_order, index), earlier(seed, 1, index));
      EXPECT_EQ(lrf::stream_seed(seed, SeedStream::densify_split, index), earlier(seed, 2, index));
    }
}

}  // namespace
