#pragma once
// What each format reader produces before the common steps (resolution choice, undistortion, crop,
// split): views with cameras at their nominal resolution (the one the poses file describes) and
// observations in that resolution's distorted pixel coordinates.
#include <functional>
#include <string>
#include <vector>

#include "lrf/scene/scene.h"

namespace lrf {

struct RawView {
  std::string name;         // sort key and display name
  std::string image_rel;    // image path relative to the scene root, inside `images_dir`
  Camera camera;            // at the nominal resolution, pinhole part of the model
  Distortion distortion;
  std::vector<Observation> observations;  // nominal-resolution, distorted pixels
};

struct RawScene {
  std::string format;
  std::string images_dir = "images";  // folder (relative to root) that image_rel starts with
  std::vector<RawView> views;
  std::vector<SfmPoint> points;
  std::string points_file;  // where `points` come from ("" if none)
  bool has_tracks = false;
  std::vector<std::string> predefined_test;  // names of test views when the format defines a split
  bool images_listed_by_order = false;       // LLFF: files in the chosen folder are matched by sorted order
};

RawScene read_colmap_scene(const std::string& root);
// The points3D file of a COLMAP model folder (.bin preferred, as read_colmap_model does); "" if none.
std::string colmap_points_path(const std::string& sparse_dir);
RawScene read_llff_scene(const std::string& root, const std::string& images_dir);
RawScene read_nerf_scene(const std::string& root);

// The file-system side of reading a transforms.json: `resolve` maps a frame's "file_path" (without a
// leading "./", never empty) to the image path relative to the scene root, throwing lrf::Error if there is
// none; `size` gives an image's size when neither the frame nor the file states "w" and "h".
struct TransformsImages {
  std::function<std::string(const std::string& file_path)> resolve;
  std::function<cv::Size(const std::string& image_rel)> size;
};
// Appends the frames of a transforms.json (NeRF synthetic, instant-ngp, nerfstudio) given as text
// (`path` names it in errors) to raw->views, and their names to *names when given.
void parse_transforms(const std::string& text, const std::string& path, const TransformsImages& images,
                      RawScene* raw, std::vector<std::string>* names);
// The images folder of a NeRF scene: the common first path component of the views' files ("" if none).
std::string common_images_dir(const std::vector<RawView>& views);

// Throws lrf::Error(path, "<where>: <what> is not a rotation ...") unless R is one: orthonormal within 1e-3
// (what a file's printed digits leave) with determinant +1. A scaled, sheared or mirrored matrix used to
// train without a word, on cameras that see a distorted scene.
void require_rotation(const Eigen::Matrix3d& R, const std::string& path, const std::string& where, const std::string& what);
// Builds the world-to-camera part of a Camera from an OpenCV camera-to-world matrix.
void set_pose_from_camera_to_world(Camera* cam, const Eigen::Matrix3d& R_c2w, const Eigen::Vector3d& center);
// Sorted file names of the images (by extension) in a folder; empty if the folder does not exist.
std::vector<std::string> list_images(const std::string& dir);

}  // namespace lrf
