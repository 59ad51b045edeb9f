#include "lrf/points/points_file.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/scene/colmap_model.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

std::string extension_of(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext;
}

template <typename T>
void put(std::string* out, T v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof v);
}

std::string ply_bytes(const std::vector<TriangulatedPoint>& points) {
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment written by lrf scene points\nelement vertex " +
                    std::to_string(points.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\n"
                    "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  for (const auto& p : points) {
    for (int k = 0; k < 3; ++k) put<float>(&out, static_cast<float>(p.xyz[k]));
    for (int k = 0; k < 3; ++k) put<uint8_t>(&out, static_cast<uint8_t>(std::lround(std::clamp(p.rgb[k], 0.f, 1.f) * 255.f)));
  }
  return out;
}

}  // namespace

void write_points_file(const std::string& path, const std::vector<TriangulatedPoint>& points) {
  const std::string ext = extension_of(path);
  if (ext == ".ply") {
    write_file_atomic(path, ply_bytes(points));
    return;
  }
  if (ext != ".bin" && ext != ".txt") fail(path, "unknown point file type: name it .bin or .txt (COLMAP points3D) or .ply");
  std::vector<ColmapPoint> colmap;
  colmap.reserve(points.size());
  for (size_t k = 0; k < points.size(); ++k) {
    ColmapPoint c;
    c.id = static_cast<int64_t>(k + 1);
    c.xyz = points[k].xyz;
    c.rgb = points[k].rgb;
    c.error = points[k].error_px;
    colmap.push_back(c);
  }
  write_colmap_points(path, colmap);
}

std::vector<SfmPoint> read_points_file(const std::string& path) {
  const std::string ext = extension_of(path);
  if (!fs::is_regular_file(path)) fail(path, "point file not found");
  if (ext != ".bin" && ext != ".txt") fail(path, "initial points must be a COLMAP points3D.bin or .txt file");
  std::vector<SfmPoint> out;
  for (const auto& p : read_colmap_points(path)) {
    if (!p.xyz.allFinite()) fail(path, "point " + std::to_string(p.id) + " has a non-finite position");
    out.push_back({p.xyz, p.rgb, p.id});
  }
  return out;
}

}  // namespace lrf
