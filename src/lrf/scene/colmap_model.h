#pragma once
// COLMAP sparse models (cameras, images, points3D) in the binary (.bin) and text (.txt) formats,
// as COLMAP stores them: world-to-camera quaternion (w,x,y,z) and translation, pixel coordinates with
// the top-left image corner at (0,0).
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "lrf/scene/camera.h"

namespace lrf {

struct ColmapCamera {
  uint32_t id = 0;
  std::string model;  // COLMAP model name, e.g. "SIMPLE_RADIAL"
  int64_t width = 0, height = 0;
  std::vector<double> params;
};

struct ColmapImage {
  uint32_t id = 0;
  Eigen::Vector4d qvec{1, 0, 0, 0};  // w, x, y, z
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
  uint32_t camera_id = 0;
  std::string name;
  std::vector<Eigen::Vector2d> xys;
  std::vector<int64_t> point3d_ids;  // -1 where the keypoint has no 3D point
};

struct ColmapPoint {
  int64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3f rgb = Eigen::Vector3f::Zero();  // [0, 1]
  double error = 0;  // mean reprojection error in pixels, as COLMAP records it
};

struct ColmapModel {
  std::map<uint32_t, ColmapCamera> cameras;
  std::vector<ColmapImage> images;  // empty if the model has no images file
  std::vector<ColmapPoint> points;
};

// Reads `dir`/{cameras,images,points3D}.{bin,txt}; .bin is preferred when both exist. Images and points
// are optional (LLFF folders often have only cameras.bin and points3D.bin).
ColmapModel read_colmap_model(const std::string& dir);
std::map<uint32_t, ColmapCamera> read_colmap_cameras(const std::string& path);
std::vector<ColmapImage> read_colmap_images(const std::string& path);
std::vector<ColmapPoint> read_colmap_points(const std::string& path);
// The same from bytes already in memory (`path` only names the source in errors).
std::map<uint32_t, ColmapCamera> parse_colmap_cameras(const std::string& bytes, const std::string& path, bool text);
std::vector<ColmapImage> parse_colmap_images(const std::string& bytes, const std::string& path, bool text);
std::vector<ColmapPoint> parse_colmap_points(const std::string& bytes, const std::string& path, bool text);
// Writes the text / binary formats (the synthetic scene, tests and fuzz seeds); points without tracks.
void write_colmap_text(const std::string& dir, const ColmapModel& model);
void write_colmap_binary(const std::string& dir, const ColmapModel& model);
// Writes a points3D file alone (text if `path` ends in .txt, else binary), atomically; without tracks,
// since there is no images file for them to refer to.
void write_colmap_points(const std::string& path, const std::vector<ColmapPoint>& points);

// Pinhole intrinsics (at the camera's own width/height) and distortion for a COLMAP camera model.
// Throws for models lrf cannot undistort (FOV, THIN_PRISM_FISHEYE) or wrong parameter counts.
void colmap_intrinsics(const ColmapCamera& cam, const std::string& path, double* fx, double* fy, double* cx,
                       double* cy, Distortion* distortion);
Eigen::Matrix3d quaternion_to_rotation(const Eigen::Vector4d& qvec);
Eigen::Vector4d rotation_to_quaternion(const Eigen::Matrix3d& R);

}  // namespace lrf
