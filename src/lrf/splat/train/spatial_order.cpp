#include "lrf/splat/train/spatial_order.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

namespace lrf::splat {
namespace {

// Spreads the low 21 bits of x so that two zero bits follow each one.
uint64_t spread_bits(uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

}  // namespace

torch::Tensor spatial_order(const torch::Tensor& means_in) {
  const auto means = means_in.detach().to(torch::kFloat32).contiguous();
  const int64_t n = means.size(0);
  const float* p = means.data_ptr<float>();
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = std::numeric_limits<float>::max(), hi[a] = std::numeric_limits<float>::lowest();
  for (int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a)
      if (std::isfinite(p[3 * i + a])) lo[a] = std::min(lo[a], p[3 * i + a]), hi[a] = std::max(hi[a], p[3 * i + a]);
  std::vector<uint64_t> code(static_cast<size_t>(n));
  at::parallel_for(0, n, 4096, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      uint64_t c = 0;
      bool finite = true;
      for (int a = 0; a < 3; ++a) {
        const float v = p[3 * i + a];
        finite = finite && std::isfinite(v);
        const double span = static_cast<double>(hi[a]) - lo[a];
        const double t = finite && span > 0 ? (v - lo[a]) / span : 0.0;
        const auto cell = static_cast<uint64_t>(std::clamp(t, 0.0, 1.0) * 2097151.0);
        c |= spread_bits(cell) << a;
      }
      code[static_cast<size_t>(i)] = finite ? c : std::numeric_limits<uint64_t>::max();
    }
  });
  std::vector<int64_t> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), int64_t{0});
  std::stable_sort(order.begin(), order.end(), [&](int64_t a, int64_t b) { return code[a] < code[b]; });
  return torch::tensor(order, torch::kInt64);
}

}  // namespace lrf::splat
