#include <algorithm>
#include <filesystem>
#include <unordered_map>

#include "lrf/core/error.h"
#include "lrf/core/finite.h"
#include "lrf/core/log.h"
#include "lrf/core/npy.h"
#include "lrf/scene/colmap_model.h"
#include "lrf/scene/colmap_reader.h"
#include "lrf/scene/llff_reader.h"

namespace fs = std::filesystem;

namespace lrf {

std::string find_sparse_dir(const std::string& root);

namespace {

// What entry (row, col) of an LLFF row's 3x5 [R | t | hwf] block holds, for error messages.
std::string llff_entry_name(int row, int col) {
  static const char* const kColumns[] = {"down", "right", "back"};
  if (col < 3) return "rotation's " + std::string(kColumns[col]) + " axis, component " + std::to_string(row);
  if (col == 3) return std::string("camera position ") + "xyz"[row];
  return row == 0 ? "image height" : row == 1 ? "image width" : "focal length";
}

}  // namespace

RawScene read_llff_scene(const std::string& root, const std::string& images_dir) {
  std::string npy_path = (fs::path(root) / "poses_bounds.npy").string();
  NpyArray a = read_npy(npy_path);
  if (a.shape.size() != 2 || a.shape[1] != 17) {
    fail(npy_path, "expected an N x 17 array (3x5 pose + near/far per image)");
  }
  const int64_t rows = a.shape[0];
  if (rows == 0) fail(npy_path, "no poses");

  RawScene raw;
  raw.format = "llff";
  raw.images_dir = images_dir;
  raw.images_listed_by_order = true;
  std::vector<std::string> files = list_images((fs::path(root) / images_dir).string());
  if (files.empty()) fail((fs::path(root) / images_dir).string(), "no images in folder");
  if (static_cast<int64_t>(files.size()) != rows) {
    fail(npy_path, std::to_string(rows) + " poses but " + std::to_string(files.size()) + " images in " +
                       (fs::path(root) / images_dir).string());
  }

  // With a COLMAP model beside the poses (LLFF's imgs2poses leaves it there) use its intrinsics,
  // distortion, points and tracks: poses_bounds.npy keeps only one pinhole focal length.
  ColmapModel model;
  std::string sparse = find_sparse_dir(root);
  if (!sparse.empty()) model = read_colmap_model(sparse);
  std::vector<const ColmapImage*> model_images;  // sorted by name, matched to rows by order
  for (const auto& im : model.images) model_images.push_back(&im);
  std::sort(model_images.begin(), model_images.end(), [](auto* x, auto* y) { return x->name < y->name; });
  if (!model_images.empty() && static_cast<int64_t>(model_images.size()) != rows) {
    log_warn(sparse + ": " + std::to_string(model_images.size()) + " images in the COLMAP model but " +
             std::to_string(rows) + " LLFF poses; ignoring the model's per-image data");
    model_images.clear();
  }
  for (const auto& p : model.points) raw.points.push_back({p.xyz, p.rgb, p.id});
  if (!sparse.empty()) raw.points_file = colmap_points_path(sparse);

  for (int64_t i = 0; i < rows; ++i) {
    const double* r = &a.data[i * 17];
    auto at = [&](int row, int col) { return r[row * 5 + col]; };
    // The near/far bounds (the last two numbers) are not used, so only the pose block is checked.
    const std::string view = "row " + std::to_string(i) + " (" + files[i] + ")";
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 5; ++col)
        col == 3 ? require_coordinate(at(row, col), npy_path, view, llff_entry_name(row, col))
                 : require_finite(at(row, col), npy_path, view, llff_entry_name(row, col));
    RawView v;
    v.name = files[i];
    v.image_rel = (fs::path(images_dir) / files[i]).string();
    double h = at(0, 4), w = at(1, 4), f = at(2, 4);
    if (!(h > 0 && w > 0 && f > 0)) fail(npy_path, "row " + std::to_string(i) + " has a non-positive h, w or focal");
    // LLFF rotation columns are (down, right, back); OpenCV's camera axes are (right, down, forward).
    Eigen::Matrix3d R_c2w;
    R_c2w.col(0) = Eigen::Vector3d(at(0, 1), at(1, 1), at(2, 1));
    R_c2w.col(1) = Eigen::Vector3d(at(0, 0), at(1, 0), at(2, 0));
    R_c2w.col(2) = -Eigen::Vector3d(at(0, 2), at(1, 2), at(2, 2));
    require_rotation(R_c2w, npy_path, view, "the pose's 3x3 block");
    Eigen::Vector3d center(at(0, 3), at(1, 3), at(2, 3));
    set_pose_from_camera_to_world(&v.camera, R_c2w, center);
    v.camera.width = static_cast<int>(std::lround(w));
    v.camera.height = static_cast<int>(std::lround(h));
    v.camera.fx = v.camera.fy = f;
    v.camera.cx = w / 2;
    v.camera.cy = h / 2;

    const ColmapCamera* cc = nullptr;
    if (!model_images.empty()) {
      cc = &model.cameras.at(model_images[i]->camera_id);
    } else if (model.cameras.size() == 1) {
      cc = &model.cameras.begin()->second;
    }
    if (cc) {
      Camera k;
      colmap_intrinsics(*cc, sparse, &k.fx, &k.fy, &k.cx, &k.cy, &v.distortion);
      k.width = static_cast<int>(cc->width);
      k.height = static_cast<int>(cc->height);
      k = k.resized(v.camera.width, v.camera.height);
      v.camera.fx = k.fx;
      v.camera.fy = k.fy;
      v.camera.cx = k.cx;
      v.camera.cy = k.cy;
    }
    if (!model_images.empty()) {
      const ColmapImage& im = *model_images[i];
      double sx = double(v.camera.width) / cc->width, sy = double(v.camera.height) / cc->height;
      for (size_t k = 0; k < im.xys.size(); ++k) {
        if (im.point3d_ids[k] >= 0) {
          v.observations.push_back({Eigen::Vector2d(im.xys[k].x() * sx, im.xys[k].y() * sy), im.point3d_ids[k]});
        }
      }
      raw.has_tracks = raw.has_tracks || !v.observations.empty();
    }
    raw.views.push_back(std::move(v));
  }
  return raw;
}

}  // namespace lrf
