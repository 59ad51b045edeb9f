#include "lrf/core/safetensors.h"

#include <algorithm>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "lrf/core/atomic_file.h"
#include "lrf/core/byte_source.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

// A JSON header larger than this is not a weights file (real ones are < 1 MB even for 1000s of tensors).
constexpr std::uint64_t kMaxHeaderBytes = 100ull << 20;
constexpr std::size_t kMaxDims = 16;

struct DtypeInfo {
  const char* name;
  at::ScalarType type;
  std::uint64_t bytes;
};

const DtypeInfo kDtypes[] = {
    {"F32", at::kFloat, 4}, {"F16", at::kHalf, 2}, {"BF16", at::kBFloat16, 2}, {"I64", at::kLong, 8},
    {"F64", at::kDouble, 8}, {"I32", at::kInt, 4}, {"U8", at::kByte, 1},     {"BOOL", at::kBool, 1},
};

const DtypeInfo* dtype_by_name(const std::string& name) {
  for (const auto& d : kDtypes)
    if (name == d.name) return &d;
  return nullptr;
}

const DtypeInfo& dtype_by_type(at::ScalarType type, const std::string& tensor_name) {
  for (const auto& d : kDtypes)
    if (d.type == type) return d;
  fail("safetensors: tensor '" + tensor_name + "' has unsupported dtype " + std::string(c10::toString(type)));
}

struct Entry {
  std::string name;
  const DtypeInfo* dtype;
  std::vector<std::int64_t> shape;
  std::uint64_t begin, end;
};

// Parses and validates the header against the data size; nothing is allocated for tensor data here.
std::vector<Entry> parse_header(ByteSource& src, std::uint64_t* data_start,
                                std::map<std::string, std::string>* metadata) {
  const std::string& name = src.name();
  if (src.size() < 8) fail(name, "not a safetensors file: shorter than its 8-byte header length");
  unsigned char len_bytes[8];
  src.read(0, len_bytes, 8);
  std::uint64_t header_len = load_le64(len_bytes);
  if (header_len > kMaxHeaderBytes) {
    fail(name, "not a safetensors file: header length " + std::to_string(header_len) + " is implausible");
  }
  if (header_len > src.size() - 8) {
    fail(name, "truncated safetensors file: header claims " + std::to_string(header_len) +
                   " bytes but the file has " + std::to_string(src.size()));
  }
  std::string text = src.read_string(8, header_len);
  nlohmann::json header;
  try {
    header = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    fail(name, std::string("safetensors header is not valid JSON: ") + e.what());
  }
  if (!header.is_object()) fail(name, "safetensors header is not a JSON object");
  *data_start = 8 + header_len;
  const std::uint64_t data_size = src.size() - *data_start;

  std::vector<Entry> entries;
  for (auto it = header.begin(); it != header.end(); ++it) {
    if (it.key() == "__metadata__") {
      if (!it.value().is_object()) fail(name, "__metadata__ is not an object");
      if (metadata) {
        for (auto m = it.value().begin(); m != it.value().end(); ++m) {
          if (!m.value().is_string()) fail(name, "__metadata__ value '" + m.key() + "' is not a string");
          (*metadata)[m.key()] = m.value().get<std::string>();
        }
      }
      continue;
    }
    const std::string where = "tensor '" + it.key() + "': ";
    const auto& v = it.value();
    if (!v.is_object() || !v.contains("dtype") || !v.contains("shape") || !v.contains("data_offsets")) {
      fail(name, where + "needs dtype, shape and data_offsets");
    }
    if (!v["dtype"].is_string()) fail(name, where + "dtype is not a string");
    Entry e;
    e.name = it.key();
    e.dtype = dtype_by_name(v["dtype"].get<std::string>());
    if (!e.dtype) fail(name, where + "unsupported dtype " + v["dtype"].get<std::string>());
    if (!v["shape"].is_array() || v["shape"].size() > kMaxDims) fail(name, where + "bad shape");
    // Element count with an overflow guard: any count whose byte size exceeds the data is refused.
    std::uint64_t count = 1;
    for (const auto& d : v["shape"]) {
      if (!d.is_number_unsigned()) fail(name, where + "shape entries must be non-negative integers");
      std::uint64_t dim = d.get<std::uint64_t>();
      if (dim > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
        fail(name, where + "shape entry too large");
      }
      e.shape.push_back(static_cast<std::int64_t>(dim));
      if (dim != 0 && count > std::numeric_limits<std::uint64_t>::max() / dim) {
        fail(name, where + "shape overflows");
      }
      count *= dim;
    }
    const auto& off = v["data_offsets"];
    if (!off.is_array() || off.size() != 2 || !off[0].is_number_unsigned() || !off[1].is_number_unsigned()) {
      fail(name, where + "data_offsets must be two non-negative integers");
    }
    e.begin = off[0].get<std::uint64_t>();
    e.end = off[1].get<std::uint64_t>();
    if (e.begin > e.end || e.end > data_size) {
      fail(name, where + "data_offsets [" + std::to_string(e.begin) + ", " + std::to_string(e.end) +
                     "] fall outside the " + std::to_string(data_size) + " data bytes (truncated file?)");
    }
    if (count > std::numeric_limits<std::uint64_t>::max() / e.dtype->bytes ||
        count * e.dtype->bytes != e.end - e.begin) {
      fail(name, where + "dtype and shape need " + std::to_string(count) + " x " +
                     std::to_string(e.dtype->bytes) + " bytes but data_offsets span " +
                     std::to_string(e.end - e.begin));
    }
    entries.push_back(std::move(e));
  }
  // Overlapping tensors would alias each other's bytes: a malformed file.
  std::vector<const Entry*> sorted;
  for (const auto& e : entries) sorted.push_back(&e);
  std::sort(sorted.begin(), sorted.end(), [](auto* a, auto* b) { return a->begin < b->begin; });
  for (std::size_t i = 1; i < sorted.size(); ++i) {
    if (sorted[i]->begin < sorted[i - 1]->end && sorted[i]->begin != sorted[i]->end) {
      fail(name, "tensors '" + sorted[i - 1]->name + "' and '" + sorted[i]->name + "' overlap");
    }
  }
  // File order = data order, which is how writers lay tensors out.
  std::stable_sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.begin < b.begin; });
  return entries;
}

StateDict read_all(ByteSource& src) {
  std::uint64_t data_start = 0;
  auto entries = parse_header(src, &data_start, nullptr);
  StateDict out;
  for (const auto& e : entries) {
    at::Tensor t = torch::empty(e.shape, torch::TensorOptions().dtype(e.dtype->type));
    src.read(data_start + e.begin, t.data_ptr(), e.end - e.begin);
    out.insert(e.name, t);
  }
  return out;
}

}  // namespace

StateDict read_safetensors(const std::string& path) {
  FileSource src(path);
  return read_all(src);
}

StateDict parse_safetensors(const std::string& bytes, const std::string& name) {
  MemorySource src(bytes, name);
  return read_all(src);
}

std::map<std::string, std::string> read_safetensors_metadata(const std::string& path) {
  FileSource src(path);
  std::uint64_t data_start = 0;
  std::map<std::string, std::string> metadata;
  parse_header(src, &data_start, &metadata);
  return metadata;
}

std::string serialize_safetensors(const StateDict& tensors, const std::map<std::string, std::string>& metadata) {
  nlohmann::ordered_json header = nlohmann::ordered_json::object();
  if (!metadata.empty()) header["__metadata__"] = metadata;
  std::vector<at::Tensor> data;
  std::uint64_t offset = 0;
  for (const auto& item : tensors) {
    if (item.key() == "__metadata__") fail("safetensors: '__metadata__' cannot be a tensor name");
    at::Tensor t = item.value().detach().to(at::kCPU).contiguous();
    const DtypeInfo& d = dtype_by_type(t.scalar_type(), item.key());
    std::uint64_t bytes = static_cast<std::uint64_t>(t.numel()) * d.bytes;
    header[item.key()] = {{"dtype", d.name}, {"shape", t.sizes().vec()}, {"data_offsets", {offset, offset + bytes}}};
    offset += bytes;
    data.push_back(t);
  }
  std::string text = header.dump();
  // Pad the header with spaces so that the data starts 8-byte aligned (as the reference writer does).
  while ((8 + text.size()) % 8 != 0) text.push_back(' ');
  std::string out;
  out.reserve(8 + text.size() + offset);
  std::uint64_t len = text.size();
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((len >> (8 * i)) & 0xff));
  out += text;
  for (const auto& t : data) {
    out.append(static_cast<const char*>(t.data_ptr()), static_cast<std::size_t>(t.nbytes()));
  }
  return out;
}

void write_safetensors(const std::string& path, const StateDict& tensors,
                       const std::map<std::string, std::string>& metadata) {
  write_file_atomic(path, serialize_safetensors(tensors, metadata));
}

bool looks_like_safetensors(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[9];
  if (!in.read(reinterpret_cast<char*>(head), 9)) return false;
  return load_le64(head) <= kMaxHeaderBytes && head[8] == '{';
}

}  // namespace lrf
