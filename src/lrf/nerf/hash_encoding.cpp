#include "lrf/nerf/hash_encoding.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <ATen/Parallel.h>

#include "lrf/core/error.h"

namespace lrf::nerf {

int HashGridSpec::resolution(int level) const {
  if (levels == 1) return base_resolution;
  const double growth = std::exp((std::log(double(max_resolution)) - std::log(double(base_resolution))) / (levels - 1));
  // The tiny epsilon keeps an exact power (e.g. 16·2^l) from rounding down to one less.
  return static_cast<int>(std::floor(base_resolution * std::pow(growth, level) + 1e-6));
}

bool HashGridSpec::level_is_dense(int level) const {
  const int64_t side = resolution(level) + 1;
  return side * side * side <= (int64_t(1) << log2_table);
}

int64_t HashGridSpec::level_entries(int level) const {
  const int64_t side = resolution(level) + 1;
  return level_is_dense(level) ? side * side * side : (int64_t(1) << log2_table);
}

int64_t HashGridSpec::level_offset(int level) const {
  int64_t offset = 0;
  for (int l = 0; l < level; ++l) offset += level_entries(l);
  return offset;
}

int64_t HashGridSpec::total_entries() const { return level_offset(levels); }

void HashGridSpec::check() const {
  auto bad = [](const std::string& what) { fail("hash grid: " + what); };
  if (levels < 1 || levels > 32) bad("levels must be 1..32, got " + std::to_string(levels));
  if (features < 1 || features > 8) bad("features per level must be 1..8, got " + std::to_string(features));
  if (log2_table < 4 || log2_table > 24) bad("log2 table size must be 4..24, got " + std::to_string(log2_table));
  if (base_resolution < 1 || base_resolution > 4096) bad("base resolution must be 1..4096");
  if (max_resolution < base_resolution || max_resolution > 1 << 16)
    bad("max resolution must be between the base resolution and 65536");
}

uint32_t grid_vertex_index(const HashGridSpec& spec, int level, uint32_t i, uint32_t j, uint32_t k) {
  if (spec.level_is_dense(level)) {
    const uint32_t side = static_cast<uint32_t>(spec.resolution(level)) + 1;
    return i + side * (j + side * k);
  }
  // Instant-NGP's spatial hash: one large prime per axis (1 for x), xor, modulo the table size.
  const uint32_t h = i ^ (j * 2654435761u) ^ (k * 805459861u);
  return h & ((1u << spec.log2_table) - 1u);
}

namespace {

// What one level needs per point, computed once per level rather than per point.
struct LevelGeometry {
  int resolution;
  bool dense;
  uint32_t side, mask;
  int64_t offset;
};

std::vector<LevelGeometry> level_geometry(const HashGridSpec& spec) {
  std::vector<LevelGeometry> g(static_cast<size_t>(spec.levels));
  for (int l = 0; l < spec.levels; ++l) {
    auto& lg = g[static_cast<size_t>(l)];
    lg.resolution = spec.resolution(l);
    lg.dense = spec.level_is_dense(l);
    lg.side = static_cast<uint32_t>(lg.resolution) + 1;
    lg.mask = (1u << spec.log2_table) - 1u;
    lg.offset = spec.level_offset(l);
  }
  return g;
}

// The 8 vertices around a point of one level: their table rows and trilinear weights.
struct Corners {
  int64_t row[8];
  float weight[8];
};

inline void corners_of(const LevelGeometry& lg, const float* p, Corners* c) {
  uint32_t cell[3];
  float frac[3];
  for (int a = 0; a < 3; ++a) {
    const float x = std::clamp(p[a], 0.0f, 1.0f) * float(lg.resolution);
    const int i = std::min(static_cast<int>(x), lg.resolution - 1);
    cell[a] = static_cast<uint32_t>(i);
    frac[a] = x - float(i);
  }
  for (int corner = 0; corner < 8; ++corner) {
    const uint32_t i = cell[0] + (corner & 1), j = cell[1] + ((corner >> 1) & 1), k = cell[2] + ((corner >> 2) & 1);
    float w = 1.0f;
    w *= (corner & 1) ? frac[0] : 1.0f - frac[0];
    w *= ((corner >> 1) & 1) ? frac[1] : 1.0f - frac[1];
    w *= ((corner >> 2) & 1) ? frac[2] : 1.0f - frac[2];
    const uint32_t index = lg.dense ? i + lg.side * (j + lg.side * k) : ((i ^ (j * 2654435761u) ^ (k * 805459861u)) & lg.mask);
    c->row[corner] = lg.offset + index;
    c->weight[corner] = w;
  }
}

}  // namespace

void hash_encode_forward(const HashGridSpec& spec, const float* table, const float* points, int64_t n, float* out) {
  const auto geometry = level_geometry(spec);
  const int F = spec.features, D = spec.output_dim();
  at::parallel_for(0, n, 256, [&](int64_t begin, int64_t end) {
    Corners c;
    for (int64_t s = begin; s < end; ++s) {
      float* o = out + s * D;
      for (int l = 0; l < spec.levels; ++l) {
        corners_of(geometry[static_cast<size_t>(l)], points + 3 * s, &c);
        for (int f = 0; f < F; ++f) {
          float v = 0.0f;
          for (int corner = 0; corner < 8; ++corner) v += c.weight[corner] * table[c.row[corner] * F + f];
          o[l * F + f] = v;
        }
      }
    }
  });
}

void hash_encode_backward(const HashGridSpec& spec, const float* points, int64_t n, const float* d_out,
                          float* d_table) {
  const auto geometry = level_geometry(spec);
  const int F = spec.features, D = spec.output_dim();
  // Each level owns a disjoint part of the table: levels run in parallel, points in order within a level.
  at::parallel_for(0, spec.levels, 1, [&](int64_t begin, int64_t end) {
    Corners c;
    for (int64_t l = begin; l < end; ++l) {
      for (int64_t s = 0; s < n; ++s) {
        const float* g = d_out + s * D + l * F;
        bool any = false;
        for (int f = 0; f < F; ++f) any = any || g[f] != 0.0f;
        if (!any) continue;
        corners_of(geometry[static_cast<size_t>(l)], points + 3 * s, &c);
        for (int corner = 0; corner < 8; ++corner)
          for (int f = 0; f < F; ++f) d_table[c.row[corner] * F + f] += c.weight[corner] * g[f];
      }
    }
  });
}

}  // namespace lrf::nerf
