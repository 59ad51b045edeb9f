#pragma once
// A scene: views (camera + image file), an optional SfM point cloud with colours, optional COLMAP tracks,
// and the train/test split. Images are decoded on demand at the resolution chosen when loading, then
// undistorted and cropped so that they match the view's (pinhole) camera exactly.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "lrf/scene/camera.h"

namespace lrf {

struct SfmPoint {
  Eigen::Vector3d xyz;
  Eigen::Vector3f rgb;  // in [0, 1]
  int64_t id = -1;
};

// One 2D observation of an SfM point, in pixels of the view's image at the resolution in use
// (undistorted, after any crop).
struct Observation {
  Eigen::Vector2d pixel;
  int64_t point_id = -1;  // COLMAP point3D_id; index into the scene's id lookup
};

struct View {
  std::string name;        // image file name, e.g. "image000.png"; views are sorted by it
  std::string image_path;  // absolute or relative path of the file actually decoded
  Camera camera;           // at the resolution in use, after undistortion and crop
  // How to turn the decoded file into the image that `camera` describes.
  int nominal_width = 0, nominal_height = 0;  // resolution the poses file describes (COLMAP's pixels)
  int file_width = 0, file_height = 0;  // size of the decoded file
  int resize_width = 0, resize_height = 0;  // after area resize (== file size when none)
  Camera distorted_camera;                  // intrinsics at resize resolution, before the crop
  Distortion distortion;
  int crop_x = 0, crop_y = 0;  // top-left of the crop window in the resized image
  std::vector<Observation> observations;  // empty unless the scene has tracks
};

struct SceneOptions {
  std::string images_dir;      // e.g. "images_8"; empty: the format's default ("images")
  int downscale = 1;           // area-resize factor applied to the chosen images
  bool crop_to_multiple_of_8 = false;  // centre crop (for latent work)
  int test_every = 8;          // test views: index % test_every == 0 (0 disables the split)
  std::string test_list;       // file with one image name per line; overrides test_every
  // Few-shot protocol: keep only this many training views, evenly spaced over the non-test views as the
  // few-shot NVS literature picks them on LLFF (0 = every non-test view). Test views are unchanged.
  int train_views = 0;
  std::string format;          // "", "colmap", "llff" or "nerf"; empty auto-detects
};

class Scene {
 public:
  std::string root;
  std::string format;  // "colmap" | "llff" | "nerf"
  std::vector<View> views;
  std::vector<int> train_indices;
  std::vector<int> test_indices;
  std::vector<SfmPoint> points;
  std::string points_file;  // the file `points` were read from ("" when the scene has none)
  bool has_tracks = false;
  // K when the training views were thinned to K (SceneOptions::train_views): the scene's own SfM points
  // then saw views that training must not, so fields triangulate their initial points from the K instead.
  int few_shot_views = 0;

  // Decodes view i as RGB float32 in [0, 1] (CV_32FC3), resized, undistorted and cropped.
  cv::Mat load_image(int i) const;
  // Same, as 8-bit RGB (CV_8UC3).
  cv::Mat load_image_u8(int i) const;
  // Scene extent as in 3DGS: 1.1 x the largest distance of a camera centre from their mean.
  double camera_extent() const;
  Eigen::Vector3d camera_mean() const;
};

// The fewest pixels per side a view may have after --downscale and the crop to multiples of 8: 32 pixels
// are 4 cells of the autoencoders' 1/8-resolution latent. Below that a latent view is a cell or two per
// side, all border for the decoder's 3x3 convolutions, with nothing left to reconstruct. (`--downscale
// 1000` on fern used to train on 1x1 images and exit 0.)
constexpr int kMinImageSide = 32;

// How view images are made from their files; fields fitted to other images are not reused by `compare` or
// `pipeline`. 2: Lanczos undistortion at the file's resolution, then the area resize (1: the resize, then a
// bilinear undistortion, which blurred every distorted scene's images).
constexpr int kViewImagesVersion = 2;

// What Scene::load_image does after decoding: `decoded` (the view's file, float RGB) undistorted at its own
// resolution, area-resized and cropped to the view's camera.
cv::Mat view_image_from_file(cv::Mat decoded, const View& v);

// Maps pixel coordinates of view `v` at its nominal resolution (as COLMAP stores keypoints) to the
// resolution in use: scaled, undistorted and shifted by the crop, like the view's camera.
std::vector<Eigen::Vector2d> nominal_to_view_pixels(const View& v, const std::vector<Eigen::Vector2d>& pixels);

// Loads the scene at `root` (auto-detecting COLMAP, LLFF or NeRF transforms.json unless
// options.format says which). Throws lrf::Error naming the file and the problem.
Scene load_scene(const std::string& root, const SceneOptions& options = {});

// Which format `root` holds ("colmap" | "llff" | "nerf"); throws if none is recognised.
std::string detect_scene_format(const std::string& root);

}  // namespace lrf
