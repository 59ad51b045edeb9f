#include "lrf/splat/raster/binning.h"

#include <omp.h>

#include <algorithm>
#include <cstring>

namespace lrf::splat {
namespace {

// Stable LSD radix sort of (key, id) pairs on 32-bit keys, 11 bits per pass. Positive IEEE floats order
// like their bit patterns, so depths sort as unsigned integers; a comparison sort costs ~10× more here.
void radix_sort(std::vector<uint32_t>& keys, std::vector<int32_t>& ids) {
  const size_t m = keys.size();
  std::vector<uint32_t> keys2(m);
  std::vector<int32_t> ids2(m);
  constexpr int kBits = 11, kBuckets = 1 << kBits;
  for (int shift = 0; shift < 32; shift += kBits) {
    size_t count[kBuckets] = {};
    for (size_t i = 0; i < m; ++i) ++count[(keys[i] >> shift) & (kBuckets - 1)];
    size_t sum = 0;
    for (int b = 0; b < kBuckets; ++b) {
      const size_t c = count[b];
      count[b] = sum;
      sum += c;
    }
    for (size_t i = 0; i < m; ++i) {
      const size_t dst = count[(keys[i] >> shift) & (kBuckets - 1)]++;
      keys2[dst] = keys[i];
      ids2[dst] = ids[i];
    }
    keys.swap(keys2);
    ids.swap(ids2);
  }
}

}  // namespace

TileBins bin_gaussians(int64_t n, const float* depth, const int32_t* rect, int tiles_x, int tiles_y) {
  const int tiles = tiles_x * tiles_y;
  // 1. Visible Gaussians in front-to-back order.
  std::vector<uint32_t> keys;
  std::vector<int32_t> order;
  keys.reserve(n);
  order.reserve(n);
  for (int64_t i = 0; i < n; ++i) {
    const int32_t* r = rect + 4 * i;
    if (r[2] <= r[0] || r[3] <= r[1]) continue;
    uint32_t bits;
    std::memcpy(&bits, depth + i, sizeof(bits));
    keys.push_back(bits);
    order.push_back(static_cast<int32_t>(i));
  }
  radix_sort(keys, order);

  // 2. Counting sort into tiles, in parallel over contiguous chunks of that order: each chunk writes its
  //    entries of a tile after those of the previous chunks, so every tile list stays depth-sorted.
  const int64_t m = static_cast<int64_t>(order.size());
  const int chunks = std::max(1, std::min<int>(omp_get_max_threads(), static_cast<int>(m / 4096) + 1));
  std::vector<std::vector<int32_t>> counts(chunks, std::vector<int32_t>(tiles, 0));
  auto chunk_begin = [&](int c) { return m * c / chunks; };
#pragma omp parallel for schedule(static) num_threads(chunks)
  for (int c = 0; c < chunks; ++c) {
    int32_t* cnt = counts[c].data();
    for (int64_t k = chunk_begin(c); k < chunk_begin(c + 1); ++k) {
      const int32_t* r = rect + 4 * order[k];
      for (int ty = r[1]; ty < r[3]; ++ty)
        for (int tx = r[0]; tx < r[2]; ++tx) ++cnt[ty * tiles_x + tx];
    }
  }
  TileBins bins;
  bins.offsets.assign(tiles + 1, 0);
  int64_t total = 0;
  for (int t = 0; t < tiles; ++t) {
    bins.offsets[t] = static_cast<int32_t>(total);
    for (int c = 0; c < chunks; ++c) {
      const int32_t cnt = counts[c][t];
      counts[c][t] = static_cast<int32_t>(total);  // becomes this chunk's write cursor in tile t
      total += cnt;
    }
  }
  bins.offsets[tiles] = static_cast<int32_t>(total);
  bins.ids.resize(total);
#pragma omp parallel for schedule(static) num_threads(chunks)
  for (int c = 0; c < chunks; ++c) {
    int32_t* cursor = counts[c].data();
    for (int64_t k = chunk_begin(c); k < chunk_begin(c + 1); ++k) {
      const int32_t g = order[k];
      const int32_t* r = rect + 4 * g;
      for (int ty = r[1]; ty < r[3]; ++ty)
        for (int tx = r[0]; tx < r[2]; ++tx) bins.ids[cursor[ty * tiles_x + tx]++] = g;
    }
  }
  return bins;
}

}  // namespace lrf::splat
