#pragma once
// Reader for NumPy .npy arrays of float64/float32 (e.g. LLFF's poses_bounds.npy), returned as float64.
#include <cstdint>
#include <string>
#include <vector>

namespace lrf {

struct NpyArray {
  std::vector<int64_t> shape;
  std::vector<double> data;  // row-major (C order)
};

NpyArray read_npy(const std::string& path);
NpyArray parse_npy(const std::string& bytes, const std::string& path);

}  // namespace lrf
