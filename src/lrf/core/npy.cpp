#include "lrf/core/npy.h"

#include <cstring>
#include <regex>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"

namespace lrf {

NpyArray read_npy(const std::string& path) { return parse_npy(read_file(path), path); }

NpyArray parse_npy(const std::string& bytes, const std::string& path) {
  if (bytes.size() < 10 || bytes.compare(0, 6, "\x93NUMPY") != 0) fail(path, "not a .npy file (bad magic)");
  int major = static_cast<unsigned char>(bytes[6]);
  size_t header_len = 0, offset = 0;
  if (major == 1) {
    header_len = static_cast<unsigned char>(bytes[8]) | (static_cast<unsigned char>(bytes[9]) << 8);
    offset = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) fail(path, "truncated .npy header");
    uint32_t len;
    std::memcpy(&len, bytes.data() + 8, 4);
    header_len = len;
    offset = 12;
  } else {
    fail(path, "unsupported .npy version " + std::to_string(major));
  }
  if (header_len > bytes.size() - offset) fail(path, "truncated .npy header");
  std::string header = bytes.substr(offset, header_len);
  offset += header_len;

  std::smatch m;
  if (!std::regex_search(header, m, std::regex("'descr'\\s*:\\s*'([^']*)'"))) fail(path, "no dtype in .npy header");
  std::string descr = m[1];
  size_t item = 0;
  if (descr == "<f8") {
    item = 8;
  } else if (descr == "<f4") {
    item = 4;
  } else {
    fail(path, "unsupported .npy dtype '" + descr + "' (expected float64 or float32)");
  }
  if (std::regex_search(header, m, std::regex("'fortran_order'\\s*:\\s*True"))) {
    fail(path, "Fortran-ordered .npy arrays are not supported");
  }
  if (!std::regex_search(header, m, std::regex("'shape'\\s*:\\s*\\(([^)]*)\\)"))) fail(path, "no shape in .npy header");
  NpyArray out;
  std::string dims = m[1];
  std::regex num("\\d+");
  uint64_t count = 1;
  for (auto it = std::sregex_iterator(dims.begin(), dims.end(), num); it != std::sregex_iterator(); ++it) {
    uint64_t d = std::stoull(it->str());
    if (d > (1ull << 40) || (d > 0 && count > (1ull << 40) / d)) fail(path, "absurd .npy shape");
    count *= d;
    out.shape.push_back(static_cast<int64_t>(d));
  }
  if (count * item != bytes.size() - offset) {
    fail(path, "corrupt .npy: shape needs " + std::to_string(count * item) + " data bytes, file has " +
                   std::to_string(bytes.size() - offset));
  }
  out.data.resize(count);
  for (uint64_t i = 0; i < count; ++i) {
    if (item == 8) {
      std::memcpy(&out.data[i], bytes.data() + offset + i * 8, 8);
    } else {
      float f;
      std::memcpy(&f, bytes.data() + offset + i * 4, 4);
      out.data[i] = f;
    }
  }
  return out;
}

}  // namespace lrf
