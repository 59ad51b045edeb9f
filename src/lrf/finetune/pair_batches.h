#pragma once
// Stage I's training data: view pairs of posed scenes with their pixel correspondences, served as
// batches of equal-sized random crops that keep matches in both crops. Everything random in a batch is
// derived from (seed, step), so a resumed run sees exactly the batches an uninterrupted one would.
#include <cstdint>
#include <string>
#include <vector>

#include <ATen/Tensor.h>
#include <opencv2/core.hpp>

#include "lrf/align/correspondences.h"
#include "lrf/scene/scene.h"

namespace lrf {

struct PairScene {
  Scene scene;  // cropped to multiples of 8
  CorrespondenceSet correspondences;  // pixels at the scene's resolution in use
  std::vector<cv::Mat> images;        // decoded once, CV_8UC3 (a quarter of float32's memory)
};

// Loads `root` with `options` (images folder, downscale) forced to crop to multiples of 8 and to use every
// view; a downscale of 0 means: the smallest integer factor that brings the longer side to at most
// `max_side` pixels. Gets its correspondences: from
// `correspondence_file` if given (it must describe the same views at the same resolution), else from
// COLMAP tracks, else SCENE/database.db, else lrf's matcher. Throws lrf::Error naming the scene if it
// has no view pair with at least `min_matches` matches.
PairScene load_pair_scene(const std::string& root, SceneOptions options, int max_side, const std::string& correspondence_file,
                          int min_matches);

// The smallest integer downscale of `root`'s images (folder `images_dir`, "" = the default) that brings
// their longer side to at most `max_side` pixels (1 when max_side <= 0).
int downscale_for_max_side(const std::string& root, const std::string& images_dir, int max_side);

struct PairBatchOptions {
  int pairs = 2;                 // view pairs per batch (2 images each)
  int crop = 256;                // square crop side in pixels (multiple of 8), reduced to fit every image
  int max_matches = 512;         // matches kept per pair (random subset), bounding the loss's cost
  int min_matches_in_crop = 8;   // a crop placement must keep at least this many matches
};

struct PairBatch {
  at::Tensor images;               // [2P, 3, S, S] in [0,1]: pair k is rows 2k (view i) and 2k+1 (view j)
  std::vector<at::Tensor> xi, xj;  // per pair, [M, 2] float pixel coordinates inside the crops
  std::vector<double> ape;         // per pair, absolute pose error of the two cameras
  std::vector<std::string> names;  // "scene:view_i|view_j", for logs
};

// The crop side used for these scenes: options.crop, reduced to the smallest image side (multiple of 8).
int effective_crop(const std::vector<PairScene>& scenes, int crop);

// Batch number `step` of a run seeded with `seed`.
PairBatch sample_pair_batch(const std::vector<PairScene>& scenes, const PairBatchOptions& options, uint64_t seed,
                            int64_t step);

}  // namespace lrf
