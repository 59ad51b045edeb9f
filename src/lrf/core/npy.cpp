#include "lrf/core/npy.h"

#include <cstring>

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

  // The header is a Python dict literal; find the three keys by hand (std::regex recurses per character
  // and can exhaust the stack on a long hostile header).
  auto value_after = [&](const std::string& key) -> size_t {
    size_t k = header.find("'" + key + "'");
    if (k == std::string::npos) fail(path, "no '" + key + "' in .npy header");
    size_t colon = header.find(':', k);
    if (colon == std::string::npos) fail(path, "malformed .npy header");
    size_t v = header.find_first_not_of(" \t", colon + 1);
    if (v == std::string::npos) fail(path, "malformed .npy header");
    return v;
  };
  size_t d = value_after("descr");
  size_t d_end = header[d] == '\'' ? header.find('\'', d + 1) : std::string::npos;
  if (d_end == std::string::npos) fail(path, "malformed dtype in .npy header");
  std::string descr = header.substr(d + 1, d_end - d - 1);
  size_t item = 0;
  if (descr == "<f8") {
    item = 8;
  } else if (descr == "<f4") {
    item = 4;
  } else {
    fail(path, "unsupported .npy dtype '" + descr + "' (expected float64 or float32)");
  }
  if (header.compare(value_after("fortran_order"), 4, "True") == 0) {
    fail(path, "Fortran-ordered .npy arrays are not supported");
  }
  size_t sh = value_after("shape");
  size_t sh_end = header[sh] == '(' ? header.find(')', sh) : std::string::npos;
  if (sh_end == std::string::npos) fail(path, "malformed shape in .npy header");
  NpyArray out;
  uint64_t count = 1;
  for (size_t i = sh + 1; i < sh_end;) {
    if (header[i] == ' ' || header[i] == ',') {
      ++i;
      continue;
    }
    if (header[i] < '0' || header[i] > '9') fail(path, "malformed shape in .npy header");
    uint64_t dim = 0;
    while (i < sh_end && header[i] >= '0' && header[i] <= '9') {
      dim = dim * 10 + static_cast<uint64_t>(header[i] - '0');
      if (dim > (1ull << 40)) fail(path, "absurd .npy shape");
      ++i;
    }
    if (dim > 0 && count > (1ull << 40) / dim) fail(path, "absurd .npy shape");
    count *= dim;
    out.shape.push_back(static_cast<int64_t>(dim));
    if (out.shape.size() > 32) fail(path, "too many dimensions in .npy shape");
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
