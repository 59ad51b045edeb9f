#include "lrf/finetune/pair_batches.h"

#include <algorithm>
#include <filesystem>
#include <random>

#include <ATen/ATen.h>
#include <opencv2/imgproc.hpp>

#include "lrf/align/correspondence_loss.h"
#include "lrf/align/correspondences_database.h"
#include "lrf/align/correspondences_io.h"
#include "lrf/align/correspondences_matching.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/seed_stream.h"

namespace lrf {
namespace {

void check_same_views(const CorrespondenceSet& set, const Scene& scene, const std::string& path) {
  if (set.view_names.size() != scene.views.size()) {
    fail(path, "describes " + std::to_string(set.view_names.size()) + " views but the scene has " +
                   std::to_string(scene.views.size()));
  }
  for (size_t i = 0; i < scene.views.size(); ++i) {
    const auto& c = scene.views[i].camera;
    if (set.view_names[i] != scene.views[i].name || set.widths[i] != c.width || set.heights[i] != c.height) {
      fail(path, "view " + std::to_string(i) + " is " + set.view_names[i] + " at " + std::to_string(set.widths[i]) +
                     "x" + std::to_string(set.heights[i]) + " but the scene has " + scene.views[i].name + " at " +
                     std::to_string(c.width) + "x" + std::to_string(c.height) +
                     " (compute it with `lrf corr` at the same resolution, with --crop8)");
    }
  }
}

// Crop origin (multiple of 8, inside the image) placing `centre` near the middle of a `side` window.
int crop_origin(double centre, double jitter, int side, int extent) {
  int o = static_cast<int>(std::floor((centre + jitter - side / 2.0) / 8.0)) * 8;
  return std::clamp(o, 0, std::max(0, (extent - side) / 8 * 8));
}

at::Tensor crop_to_tensor(const cv::Mat& u8, int x, int y, int side) {
  cv::Mat crop = u8(cv::Rect(x, y, side, side));
  cv::Mat f;
  crop.convertTo(f, CV_32FC3, 1.0 / 255.0);
  return at::from_blob(f.data, {side, side, 3}, at::kFloat).permute({2, 0, 1}).clone();
}

at::Tensor points_tensor(const std::vector<Eigen::Vector2f>& p) {
  at::Tensor t = at::empty({static_cast<int64_t>(p.size()), 2}, at::kFloat);
  auto a = t.accessor<float, 2>();
  for (size_t k = 0; k < p.size(); ++k) {
    a[k][0] = p[k].x();
    a[k][1] = p[k].y();
  }
  return t;
}

}  // namespace

int downscale_for_max_side(const std::string& root, const std::string& images_dir, int max_side) {
  if (max_side <= 0) return 1;
  SceneOptions probe_options;
  probe_options.images_dir = images_dir;
  Scene probe = load_scene(root, probe_options);
  int longest = 0;
  for (const auto& v : probe.views) longest = std::max({longest, v.file_width, v.file_height});
  return std::max(1, (longest + max_side - 1) / max_side);
}

PairScene load_pair_scene(const std::string& root, SceneOptions so, int max_side,
                          const std::string& correspondence_file, int min_matches) {
  if (so.downscale <= 0) so.downscale = downscale_for_max_side(root, so.images_dir, max_side);
  so.crop_to_multiple_of_8 = true;
  so.test_every = 0;  // every view of a training scene is used
  PairScene ps;
  ps.scene = load_scene(root, so);
  const Scene& scene = ps.scene;
  if (!correspondence_file.empty()) {
    ps.correspondences = read_correspondences(correspondence_file);
    check_same_views(ps.correspondences, scene, correspondence_file);
  } else if (scene.has_tracks) {
    ps.correspondences = correspondences_from_tracks(scene, min_matches);
  } else if (std::filesystem::exists(std::filesystem::path(root) / "database.db")) {
    ps.correspondences =
        correspondences_from_database(scene, (std::filesystem::path(root) / "database.db").string(), min_matches);
  } else {
    MatchOptions mo;
    mo.min_inliers = min_matches;
    log_info(root + ": no COLMAP tracks or database.db; matching SIFT features (" + std::to_string(scene.views.size()) +
             " views)");
    ps.correspondences = correspondences_from_matching(scene, mo);
  }
  auto& pairs = ps.correspondences.pairs;
  pairs.erase(std::remove_if(pairs.begin(), pairs.end(),
                             [&](const ViewPairMatches& p) { return static_cast<int>(p.xi.size()) < min_matches; }),
              pairs.end());
  if (pairs.empty()) {
    fail(root, "no view pair has " + std::to_string(min_matches) +
                   " or more correspondences (source " + ps.correspondences.source +
                   "); Stage I needs overlapping posed views");
  }
  ps.images.reserve(scene.views.size());
  for (size_t i = 0; i < scene.views.size(); ++i) ps.images.push_back(scene.load_image_u8(static_cast<int>(i)));
  log_info(root + ": " + std::to_string(scene.views.size()) + " views at " + std::to_string(scene.views[0].camera.width) +
           "x" + std::to_string(scene.views[0].camera.height) + " (downscale " + std::to_string(so.downscale) + "), " +
           std::to_string(pairs.size()) + " pairs from " + ps.correspondences.source);
  return ps;
}

int effective_crop(const std::vector<PairScene>& scenes, int crop) {
  int side = crop / 8 * 8;
  for (const auto& s : scenes) {
    for (const auto& v : s.scene.views) side = std::min({side, v.camera.width / 8 * 8, v.camera.height / 8 * 8});
  }
  if (side < 8) fail("crop size " + std::to_string(crop) + " leaves less than 8 pixels");
  return side;
}

PairBatch sample_pair_batch(const std::vector<PairScene>& scenes, const PairBatchOptions& options, uint64_t seed,
                            int64_t step) {
  if (scenes.empty()) fail("Stage I needs at least one scene");
  const int side = effective_crop(scenes, options.crop);
  std::mt19937_64 rng(stream_seed(seed, SeedStream::stage1_pairs, static_cast<uint64_t>(step)));
  // Scenes are drawn in proportion to their pairs' count, i.e. every pair equally often.
  std::vector<double> counts;
  for (const auto& s : scenes) counts.push_back(static_cast<double>(s.correspondences.pairs.size()));
  std::discrete_distribution<size_t> pick_scene(counts.begin(), counts.end());
  std::uniform_real_distribution<double> jitter(-side / 4.0, side / 4.0);

  PairBatch batch;
  std::vector<at::Tensor> crops;
  for (int k = 0; k < options.pairs; ++k) {
    const PairScene& s = scenes[pick_scene(rng)];
    const auto& pairs = s.correspondences.pairs;
    const ViewPairMatches& pair = pairs[std::uniform_int_distribution<size_t>(0, pairs.size() - 1)(rng)];
    const Camera& ci = s.scene.views[pair.view_i].camera;
    const Camera& cj = s.scene.views[pair.view_j].camera;
    std::vector<Eigen::Vector2f> best_i, best_j;
    int best_x[2] = {0, 0}, best_y[2] = {0, 0};
    for (int attempt = 0; attempt < 8; ++attempt) {
      size_t m = std::uniform_int_distribution<size_t>(0, pair.xi.size() - 1)(rng);
      int xi0 = crop_origin(pair.xi[m].x(), jitter(rng), side, ci.width);
      int yi0 = crop_origin(pair.xi[m].y(), jitter(rng), side, ci.height);
      int xj0 = crop_origin(pair.xj[m].x(), jitter(rng), side, cj.width);
      int yj0 = crop_origin(pair.xj[m].y(), jitter(rng), side, cj.height);
      std::vector<Eigen::Vector2f> in_i, in_j;
      for (size_t q = 0; q < pair.xi.size(); ++q) {
        Eigen::Vector2f a = pair.xi[q] - Eigen::Vector2f(xi0, yi0), b = pair.xj[q] - Eigen::Vector2f(xj0, yj0);
        if (a.x() >= 0 && a.y() >= 0 && a.x() < side && a.y() < side && b.x() >= 0 && b.y() >= 0 && b.x() < side &&
            b.y() < side) {
          in_i.push_back(a);
          in_j.push_back(b);
        }
      }
      if (in_i.size() > best_i.size()) {
        best_i = std::move(in_i);
        best_j = std::move(in_j);
        best_x[0] = xi0, best_y[0] = yi0, best_x[1] = xj0, best_y[1] = yj0;
      }
      if (static_cast<int>(best_i.size()) >= options.min_matches_in_crop) break;
    }
    // Keep a bounded random subset (a partial Fisher-Yates shuffle, driven by the step's generator).
    const size_t keep = std::min(best_i.size(), static_cast<size_t>(std::max(1, options.max_matches)));
    for (size_t q = 0; q < keep; ++q) {
      size_t r = std::uniform_int_distribution<size_t>(q, best_i.size() - 1)(rng);
      std::swap(best_i[q], best_i[r]);
      std::swap(best_j[q], best_j[r]);
    }
    best_i.resize(keep);
    best_j.resize(keep);
    crops.push_back(crop_to_tensor(s.images[pair.view_i], best_x[0], best_y[0], side));
    crops.push_back(crop_to_tensor(s.images[pair.view_j], best_x[1], best_y[1], side));
    batch.xi.push_back(points_tensor(best_i));
    batch.xj.push_back(points_tensor(best_j));
    batch.ape.push_back(absolute_pose_error(ci, cj));
    batch.names.push_back(std::filesystem::path(s.scene.root).filename().string() + ":" +
                          s.scene.views[pair.view_i].name + "|" + s.scene.views[pair.view_j].name);
  }
  batch.images = at::stack(crops);
  return batch;
}

}  // namespace lrf
