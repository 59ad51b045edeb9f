#include "lrf/scene/camera.h"

#include <cmath>
#include <cstdio>

#include "lrf/core/error.h"

#include "lrf/scene/raw_scene.h"

namespace lrf {

void require_rotation(const Eigen::Matrix3d& R, const std::string& path, const std::string& where, const std::string& what) {
  const double off = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = R.determinant();
  if (off <= 1e-3 && det > 0) return;
  char text[160];
  std::snprintf(text, sizeof text, "its columns have lengths %.4g, %.4g, %.4g and its determinant is %.4g", R.col(0).norm(),
                R.col(1).norm(), R.col(2).norm(), det);
  fail(path, where + ": " + what + " is not a rotation (" + text +
                 "; a rotation's are 1, 1, 1 and 1): a scaled, sheared or mirrored camera cannot be used");
}

void set_pose_from_camera_to_world(Camera* cam, const Eigen::Matrix3d& R_c2w, const Eigen::Vector3d& center) {
  cam->R = R_c2w.transpose();
  cam->t = -cam->R * center;
}

Eigen::Matrix4d Camera::world_to_camera() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = R;
  m.topRightCorner<3, 1>() = t;
  return m;
}

Eigen::Matrix4d Camera::camera_to_world() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = R.transpose();
  m.topRightCorner<3, 1>() = center();
  return m;
}

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

bool Camera::project(const Eigen::Vector3d& world, Eigen::Vector2d* pixel, double* depth) const {
  Eigen::Vector3d p = R * world + t;
  if (depth) *depth = p.z();
  if (p.z() <= 0) return false;
  if (pixel) *pixel = {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
  return true;
}

Camera Camera::resized(int new_width, int new_height) const {
  // Pixel centres sit at +0.5, so scaling maps continuous coordinates x -> x * s exactly.
  Camera c = *this;
  double sx = double(new_width) / width, sy = double(new_height) / height;
  c.width = new_width;
  c.height = new_height;
  c.fx *= sx;
  c.cx *= sx;
  c.fy *= sy;
  c.cy *= sy;
  return c;
}

Camera Camera::cropped(int x0, int y0, int w, int h) const {
  Camera c = *this;
  c.width = w;
  c.height = h;
  c.cx -= x0;
  c.cy -= y0;
  return c;
}

double Camera::fov_x() const { return 2.0 * std::atan(width / (2.0 * fx)); }
double Camera::fov_y() const { return 2.0 * std::atan(height / (2.0 * fy)); }

bool Distortion::any() const {
  for (double v : k)
    if (v != 0) return true;
  return false;
}

}  // namespace lrf
