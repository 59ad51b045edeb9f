#include <cstring>

#include <nlohmann/json.hpp>

#include "lrf/align/correspondences_io.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/binary_reader.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {
constexpr char kMagic[8] = {'L', 'R', 'F', 'C', 'O', 'R', 'R', '1'};
constexpr uint32_t kMaxHeader = 64u << 20;
constexpr int64_t kMaxImageSide = 1 << 16;

template <typename T>
void put(std::string* out, T v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof v);
}
}  // namespace

void write_correspondences(const std::string& path, const CorrespondenceSet& set) {
  nlohmann::json h = {{"scene", set.scene}, {"source", set.source}, {"views", set.view_names},
                      {"widths", set.widths}, {"heights", set.heights}, {"pairs", set.pairs.size()}};
  std::string header = h.dump();
  std::string out(kMagic, 8);
  put<uint32_t>(&out, static_cast<uint32_t>(header.size()));
  out += header;
  for (const auto& p : set.pairs) {
    put<int32_t>(&out, p.view_i);
    put<int32_t>(&out, p.view_j);
    put<uint32_t>(&out, static_cast<uint32_t>(p.xi.size()));
    for (size_t k = 0; k < p.xi.size(); ++k) {
      put<float>(&out, p.xi[k].x());
      put<float>(&out, p.xi[k].y());
      put<float>(&out, p.xj[k].x());
      put<float>(&out, p.xj[k].y());
    }
  }
  write_file_atomic(path, out);
}

CorrespondenceSet read_correspondences(const std::string& path) { return parse_correspondences(read_file(path), path); }

CorrespondenceSet parse_correspondences(const std::string& bytes, const std::string& path) {
  if (bytes.size() < 12 || std::memcmp(bytes.data(), kMagic, 8) != 0) {
    fail(path, "not an lrf correspondence file (bad magic)");
  }
  BinaryReader r(bytes.substr(8), path);
  uint32_t hlen = r.read<uint32_t>();
  if (hlen > kMaxHeader || hlen > r.remaining()) fail(path, "truncated or corrupt correspondence header");
  std::string header = bytes.substr(12, hlen);
  BinaryReader body(bytes.substr(12 + hlen), path);
  CorrespondenceSet set;
  uint64_t npairs = 0;
  try {
    auto h = nlohmann::json::parse(header);
    set.scene = h.at("scene").get<std::string>();
    set.source = h.at("source").get<std::string>();
    set.view_names = h.at("views").get<std::vector<std::string>>();
    // Image sizes: integers in range (get<int> from a float such as 2.4e25 would be undefined behaviour).
    for (auto [key, out] : {std::pair<const char*, std::vector<int>*>{"widths", &set.widths}, {"heights", &set.heights}}) {
      const auto& list = h.at(key);
      if (!list.is_array()) fail(path, std::string("header: \"") + key + "\" is not a list");
      for (const auto& v : list) {
        if (!v.is_number_integer() || v.get<int64_t>() < 1 || v.get<int64_t>() > kMaxImageSide)
          fail(path, std::string("header: \"") + key + "\" holds a value that is not a size of 1 to " +
                         std::to_string(kMaxImageSide) + " pixels");
        out->push_back(static_cast<int>(v.get<int64_t>()));
      }
    }
    if (!h.at("pairs").is_number_unsigned()) fail(path, "header: \"pairs\" is not a count");
    npairs = h.at("pairs").get<uint64_t>();
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("corrupt correspondence header: ") + e.what());
  }
  const size_t views = set.view_names.size();
  if (set.widths.size() != views || set.heights.size() != views) fail(path, "header: view sizes do not match views");
  body.require_records(npairs, 12, "view pairs");
  set.pairs.resize(npairs);
  for (auto& p : set.pairs) {
    p.view_i = body.read<int32_t>();
    p.view_j = body.read<int32_t>();
    if (p.view_i < 0 || p.view_j < 0 || size_t(p.view_i) >= views || size_t(p.view_j) >= views || p.view_i == p.view_j) {
      fail(path, "pair refers to views " + std::to_string(p.view_i) + ", " + std::to_string(p.view_j) + " of " +
                     std::to_string(views));
    }
    uint32_t n = body.read<uint32_t>();
    body.require_records(n, 16, "matches");
    p.xi.resize(n);
    p.xj.resize(n);
    for (uint32_t k = 0; k < n; ++k) {
      p.xi[k].x() = body.read<float>();
      p.xi[k].y() = body.read<float>();
      p.xj[k].x() = body.read<float>();
      p.xj[k].y() = body.read<float>();
      if (!p.xi[k].allFinite() || !p.xj[k].allFinite()) fail(path, "non-finite match coordinates");
    }
  }
  if (body.remaining() != 0) fail(path, "trailing bytes after the last pair");
  return set;
}

}  // namespace lrf
