#include "lrf/splat/ply_io.h"

#include <cmath>
#include <cstring>
#include <sstream>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"

namespace lrf::splat {
namespace {

bool little_endian_host() {
  const uint16_t one = 1;
  uint8_t b;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

std::vector<std::string> property_names(int channels, int rest_coeffs) {
  std::vector<std::string> names = {"x", "y", "z", "nx", "ny", "nz"};
  for (int c = 0; c < channels; ++c) names.push_back("f_dc_" + std::to_string(c));
  for (int i = 0; i < channels * rest_coeffs; ++i) names.push_back("f_rest_" + std::to_string(i));
  names.push_back("opacity");
  for (int i = 0; i < 3; ++i) names.push_back("scale_" + std::to_string(i));
  for (int i = 0; i < 4; ++i) names.push_back("rot_" + std::to_string(i));
  return names;
}

}  // namespace

void write_ply(const std::string& path, const Gaussians& g) {
  if (!little_endian_host()) fail(path, "writing .ply needs a little-endian host");
  g.check(path);
  const int64_t n = g.size();
  const int c = g.channels();
  const int rest = static_cast<int>(g.sh.size(1)) - 1;
  auto names = property_names(c, rest);
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\nelement vertex " << n << "\n";
  for (auto& name : names) header << "property float " << name << "\n";
  header << "end_header\n";

  // One [N, P] float table in file order.
  auto means = g.means.detach().to(torch::kFloat32);
  auto dc = g.sh_dc().detach().reshape({n, c});
  // [N, K-1, C] -> channel-major [N, C, K-1] -> [N, C*(K-1)]
  auto rest_t = g.sh_rest().detach().transpose(1, 2).reshape({n, c * rest});
  auto table = torch::cat({means, torch::zeros({n, 3}), dc, rest_t, g.opacity_logits.detach(),
                           g.log_scales.detach(), g.quats.detach()},
                          1)
                   .to(torch::kFloat32)
                   .contiguous();
  std::string bytes = header.str();
  const size_t body = static_cast<size_t>(table.numel()) * sizeof(float);
  const size_t head = bytes.size();
  bytes.resize(head + body);
  std::memcpy(bytes.data() + head, table.data_ptr<float>(), body);
  write_file_atomic(path, bytes);
}

Gaussians read_ply(const std::string& path, int channels) { return parse_ply(read_file(path), path, channels); }

Gaussians parse_ply(const std::string& bytes, const std::string& path, int channels) {
  if (!little_endian_host()) fail(path, "reading .ply needs a little-endian host");
  const size_t end = bytes.find("end_header\n");
  if (bytes.compare(0, 4, "ply\n") != 0 || end == std::string::npos)
    fail(path, "not a .ply file (missing 'ply' magic or 'end_header')");
  std::istringstream header(bytes.substr(0, end));
  std::string line;
  int64_t count = -1;
  bool binary_le = false;
  std::vector<std::string> props;
  bool in_vertex = false;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "format") {
      std::string fmt;
      words >> fmt;
      binary_le = fmt == "binary_little_endian";
    } else if (key == "element") {
      std::string name;
      int64_t k = -1;
      words >> name >> k;
      if (name == "vertex") {
        if (k < 0) fail(path, "bad vertex count in header");
        count = k;
        in_vertex = true;
      } else {
        if (k != 0) fail(path, "unexpected element '" + name + "' (only 'vertex' is supported)");
        in_vertex = false;
      }
    } else if (key == "property") {
      std::string type, name;
      words >> type >> name;
      if (!in_vertex) fail(path, "property outside the vertex element: " + name);
      if (type != "float" && type != "float32")
        fail(path, "property '" + name + "' has type '" + type + "', expected float");
      props.push_back(name);
    }
  }
  if (!binary_le) fail(path, "only 'format binary_little_endian 1.0' is supported");
  if (count < 0) fail(path, "no vertex element");
  int dc = 0, rest_total = 0;
  for (auto& p : props) {
    if (p.rfind("f_dc_", 0) == 0) ++dc;
    if (p.rfind("f_rest_", 0) == 0) ++rest_total;
  }
  if (dc == 0) fail(path, "no f_dc_* properties: not a Gaussian splatting .ply");
  if (channels > 0 && dc != channels)
    fail(path, "has " + std::to_string(dc) + " feature channels, expected " + std::to_string(channels));
  if (rest_total % dc != 0) fail(path, "f_rest_* count is not a multiple of the channel count");
  const int rest = rest_total / dc;
  int degree = -1;
  for (int d = 0; d <= 3; ++d)
    if (sh_coefficients(d) - 1 == rest) degree = d;
  if (degree < 0) fail(path, std::to_string(rest) + " higher SH coefficients per channel is not an SH degree 0..3");
  auto expected = property_names(dc, rest);
  if (props != expected) {
    // Name the first difference: that is what the user needs to fix.
    size_t i = 0;
    while (i < props.size() && i < expected.size() && props[i] == expected[i]) ++i;
    std::string got = i < props.size() ? props[i] : "(end)";
    std::string want = i < expected.size() ? expected[i] : "(end)";
    fail(path, "unexpected vertex properties: property " + std::to_string(i) + " is '" + got +
                   "', expected '" + want + "' (Inria layout: x y z nx ny nz f_dc_* f_rest_* opacity "
                   "scale_0..2 rot_0..3)");
  }
  const size_t p = expected.size();
  const size_t data_start = end + std::strlen("end_header\n");
  const size_t available = bytes.size() - data_start;
  if (static_cast<uint64_t>(count) > available / (p * sizeof(float)))
    fail(path, "header announces " + std::to_string(count) + " vertices but the file holds only " +
                   std::to_string(available / (p * sizeof(float))) + " (truncated?)");
  auto table = torch::empty({count, static_cast<int64_t>(p)}, torch::kFloat32);
  // An empty field (0 vertices) has no data pointer to copy to (memcpy to null is undefined even for 0 bytes).
  if (table.numel() > 0)
    std::memcpy(table.data_ptr<float>(), bytes.data() + data_start, static_cast<size_t>(table.numel()) * sizeof(float));

  Gaussians g;
  g.max_sh_degree = degree;
  int64_t col = 0;
  auto take = [&](int64_t k) {
    auto t = table.narrow(1, col, k);
    col += k;
    return t;
  };
  g.means = take(3);
  take(3);  // normals: unused
  auto f_dc = take(dc);
  auto f_rest = take(static_cast<int64_t>(dc) * rest);
  g.opacity_logits = take(1);
  g.log_scales = take(3);
  g.quats = take(4);
  g.sh = torch::cat({f_dc.reshape({count, 1, dc}), f_rest.reshape({count, dc, rest}).transpose(1, 2)}, 1);
  if (!torch::isfinite(table).all().item<bool>()) fail(path, "contains NaN or infinite values");
  g.make_leaves();
  return g;
}

}  // namespace lrf::splat
