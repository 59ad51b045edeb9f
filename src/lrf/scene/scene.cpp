#include "lrf/scene/scene.h"

#include <algorithm>

#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/scene/undistort.h"

namespace lrf {

cv::Mat Scene::load_image(int i) const {
  if (i < 0 || i >= static_cast<int>(views.size())) fail("view index " + std::to_string(i) + " out of range");
  const View& v = views[i];
  cv::Mat img = read_image_rgb(v.image_path, ExifOrientation::as_stored);
  if (img.cols != v.file_width || img.rows != v.file_height) {
    fail(v.image_path, "image is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) + ", expected " +
                           std::to_string(v.file_width) + "x" + std::to_string(v.file_height) +
                           " (images of mixed sizes, or not matching the camera model)");
  }
  return view_image_from_file(img, v);
}

cv::Mat view_image_from_file(cv::Mat img, const View& v) {
  // Undistort before the area resize: the remap interpolates between pixels, and on the file's finer grid
  // the resize then averages most of that interpolation's blur away.
  if (v.distortion.any()) img = undistort_image(img, v.distorted_camera.resized(img.cols, img.rows), v.distortion);
  img = resize_area(img, v.resize_width, v.resize_height);
  if (v.crop_x || v.crop_y || v.camera.width != img.cols || v.camera.height != img.rows) {
    img = img(cv::Rect(v.crop_x, v.crop_y, v.camera.width, v.camera.height)).clone();
  }
  return img;
}

cv::Mat Scene::load_image_u8(int i) const { return to_u8(load_image(i)); }

Eigen::Vector3d Scene::camera_mean() const {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& v : views) mean += v.camera.center();
  return views.empty() ? mean : Eigen::Vector3d(mean / double(views.size()));
}

double Scene::camera_extent() const {
  Eigen::Vector3d mean = camera_mean();
  double radius = 0;
  for (const auto& v : views) radius = std::max(radius, (v.camera.center() - mean).norm());
  return 1.1 * radius;
}

}  // namespace lrf
