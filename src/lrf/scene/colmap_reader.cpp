#include <filesystem>
#include <unordered_map>

#include "lrf/core/error.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/colmap_reader.h"

namespace fs = std::filesystem;

namespace lrf {

// The sparse model folder: sparse/0 (COLMAP's mapper output) or sparse/ itself.
std::string find_sparse_dir(const std::string& root) {
  for (const char* sub : {"sparse/0", "sparse"}) {
    fs::path dir = fs::path(root) / sub;
    if (fs::exists(dir / "cameras.bin") || fs::exists(dir / "cameras.txt")) return dir.string();
  }
  return "";
}

std::string colmap_points_path(const std::string& sparse_dir) {
  for (const char* name : {"points3D.bin", "points3D.txt"}) {
    fs::path p = fs::path(sparse_dir) / name;
    if (fs::exists(p)) return p.string();
  }
  return "";
}

RawScene read_colmap_scene(const std::string& root) {
  std::string dir = find_sparse_dir(root);
  if (dir.empty()) fail(root, "no COLMAP model (sparse/0/cameras.bin or .txt)");
  ColmapModel model = read_colmap_model(dir);
  if (model.images.empty()) fail(dir, "COLMAP model has no images.bin / images.txt (no camera poses)");

  RawScene raw;
  raw.format = "colmap";
  for (const auto& p : model.points) raw.points.push_back({p.xyz, p.rgb, p.id});
  raw.points_file = colmap_points_path(dir);
  std::unordered_map<int64_t, bool> known_point;
  for (const auto& p : model.points) known_point[p.id] = true;

  for (const auto& im : model.images) {
    const ColmapCamera& cc = model.cameras.at(im.camera_id);
    RawView v;
    v.name = im.name;
    v.image_rel = (fs::path("images") / im.name).string();
    v.camera.width = static_cast<int>(cc.width);
    v.camera.height = static_cast<int>(cc.height);
    colmap_intrinsics(cc, dir, &v.camera.fx, &v.camera.fy, &v.camera.cx, &v.camera.cy, &v.distortion);
    v.camera.R = quaternion_to_rotation(im.qvec);
    v.camera.t = im.tvec;
    for (size_t k = 0; k < im.xys.size(); ++k) {
      if (im.point3d_ids[k] >= 0 && known_point.count(im.point3d_ids[k])) {
        v.observations.push_back({im.xys[k], im.point3d_ids[k]});
      }
    }
    raw.has_tracks = raw.has_tracks || !v.observations.empty();
    raw.views.push_back(std::move(v));
  }
  return raw;
}

}  // namespace lrf
