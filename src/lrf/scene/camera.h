#pragma once
// The one camera convention inside lrf: OpenCV axes (x right, y down, z forward), world-to-camera
// rotation R and translation t (x_cam = R x_world + t), pinhole intrinsics at the resolution in use,
// pixel centres at integer + 0.5 (the pixel (i, j) covers [j, j+1) x [i, i+1)).
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lrf {

struct Camera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // world -> camera
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  Eigen::Vector3d center() const { return -R.transpose() * t; }
  Eigen::Matrix4d world_to_camera() const;
  Eigen::Matrix4d camera_to_world() const;
  Eigen::Matrix3d K() const;
  // Projects a world point to pixel coordinates; returns false when it is behind the camera.
  bool project(const Eigen::Vector3d& world, Eigen::Vector2d* pixel, double* depth = nullptr) const;
  // The same camera seen through an image resized to new_width x new_height (intrinsics scaled).
  Camera resized(int new_width, int new_height) const;
  // The same camera seen through the window [x0, x0+w) x [y0, y0+h) of its image.
  Camera cropped(int x0, int y0, int w, int h) const;
  double fov_x() const;
  double fov_y() const;
};

// Lens distortion in OpenCV's (k1, k2, p1, p2, k3, k4, k5, k6) order; all zero means pinhole.
struct Distortion {
  double k[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  bool fisheye = false;  // OPENCV_FISHEYE / *_RADIAL_FISHEYE: k[0..3] are the fisheye k1..k4
  bool any() const;
};

// Throws lrf::Error(path, "<where>: <what> is not a rotation ...") unless R is one: orthonormal within 1e-3
// (what a file's printed digits leave) with determinant +1. A scaled, sheared or mirrored matrix used to
// train without a word, on cameras that see a distorted scene.
void require_rotation(const Eigen::Matrix3d& R, const std::string& path, const std::string& where, const std::string& what);
// Builds the world-to-camera part of a Camera from an OpenCV camera-to-world matrix.
void set_pose_from_camera_to_world(Camera* cam, const Eigen::Matrix3d& R_c2w, const Eigen::Vector3d& center);

}  // namespace lrf
