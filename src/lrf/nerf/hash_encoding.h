#pragma once
// The multiresolution hash encoding of Instant-NGP: L grids of growing resolution over the unit cube,
// each vertex holding F trainable features. A point's encoding is, per level, the trilinear interpolation
// of the 8 vertices around it, all levels concatenated (L·F values). Coarse levels small enough to fit
// their table are indexed densely; finer ones through a spatial hash, so that collisions are shared
// (and averaged out by the finer levels and the MLP that reads them).
//
// The kernels are plain loops over raw float arrays (no torch inside them): forward per point, backward
// per level, so that the scatter into each level's table is race-free and deterministic for any thread count.
#include <cstdint>
#include <vector>

namespace lrf::nerf {

struct HashGridSpec {
  int levels = 16;
  int features = 2;         // per level
  int log2_table = 17;      // entries per hashed level: 2^log2_table
  int base_resolution = 16; // cells per axis of the coarsest level
  int max_resolution = 512; // cells per axis of the finest level

  int output_dim() const { return levels * features; }
  // Cells per axis of level l: base · b^l rounded down, b chosen so the finest level has max_resolution.
  int resolution(int level) const;
  // Vertices stored for level l: (res+1)^3 when that fits the hashed size (dense), else 2^log2_table.
  int64_t level_entries(int level) const;
  bool level_is_dense(int level) const;
  // Offset of level l's first entry (entries, not floats) in the concatenated table.
  int64_t level_offset(int level) const;
  int64_t total_entries() const;
  int64_t parameter_count() const { return total_entries() * features; }
  // Throws lrf::Error naming the setting when one is out of range.
  void check() const;
};

// The index of vertex (i, j, k) of a level with `resolution` cells per axis, in that level's table.
uint32_t grid_vertex_index(const HashGridSpec& spec, int level, uint32_t i, uint32_t j, uint32_t k);

// points: [n, 3] in [0, 1] (values outside are clamped); table: [total_entries, features];
// out: [n, output_dim] (level-major: level l's features at l·F .. l·F + F − 1).
void hash_encode_forward(const HashGridSpec& spec, const float* table, const float* points, int64_t n, float* out);

// d_table += ∂(Σ d_out · out)/∂table for the same points: d_out [n, output_dim], d_table like table.
void hash_encode_backward(const HashGridSpec& spec, const float* points, int64_t n, const float* d_out,
                          float* d_table);

}  // namespace lrf::nerf
