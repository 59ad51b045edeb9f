#pragma once
// What each format reader produces before the common steps (resolution choice, undistortion, crop,
// split): views with cameras at their nominal resolution (the one the poses file describes) and
// observations in that resolution's distorted pixel coordinates. Each reader has its own file:
// colmap_reader.h, llff_reader.h, nerf_reader.h (transforms_json.h: the transforms.json it reads).
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

// Sorted file names of the images (by extension) in a folder; empty if the folder does not exist.
std::vector<std::string> list_images(const std::string& dir);

}  // namespace lrf
