#include "lrf/points/scene_triangulation.h"

#include <algorithm>
#include <cmath>

#include "lrf/align/correspondences_database.h"
#include "lrf/align/correspondences_matching.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/progress.h"
#include "lrf/points/tracks.h"
#include "lrf/points/triangulation.h"
#include "lrf/points/view_pairs.h"

namespace lrf {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Bilinear sample of an 8-bit RGB image at an lrf pixel position (centres at +0.5), in [0, 1].
Eigen::Vector3f sample_rgb(const cv::Mat& image, const Eigen::Vector2d& pixel) {
  const double x = std::clamp(pixel.x() - 0.5, 0.0, image.cols - 1.0), y = std::clamp(pixel.y() - 0.5, 0.0, image.rows - 1.0);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, image.rows - 1);
  const double ax = x - x0, ay = y - y0;
  Eigen::Vector3f out = Eigen::Vector3f::Zero();
  auto add = [&](int yy, int xx, double w) {
    const cv::Vec3b& p = image.at<cv::Vec3b>(yy, xx);
    for (int c = 0; c < 3; ++c) out[c] += static_cast<float>(w * p[c] / 255.0);
  };
  add(y0, x0, (1 - ax) * (1 - ay));
  add(y0, x1, ax * (1 - ay));
  add(y1, x0, (1 - ax) * ay);
  add(y1, x1, ax * ay);
  return out;
}

std::vector<int> participating_views(const Scene& scene, bool training_only) {
  if (training_only) return scene.train_indices;
  std::vector<int> ids(scene.views.size());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<int>(i);
  return ids;
}

}  // namespace

nlohmann::json TriangulationStats::to_json() const {
  return {{"views", views},
          {"pairs", pairs},
          {"matches", matches},
          {"tracks", tracks},
          {"points", points},
          {"rejected_too_short", too_short},
          {"rejected_inconsistent", inconsistent},
          {"mean_error_px", mean_error_px},
          {"median_error_px", median_error_px},
          {"mean_track_length", mean_track_length},
          {"median_angle_deg", median_angle_deg}};
}

TriangulatedPoints triangulate_scene(const Scene& scene, const TriangulationOptions& o) {
  if (o.min_track_length < 2) fail_usage("--min-track-length must be at least 2");
  if (!(o.max_error_px > 0)) fail_usage("--max-error must be positive");
  if (!(o.min_angle_deg >= 0 && o.min_angle_deg < 90)) fail_usage("--min-angle must be in [0, 90) degrees");
  const std::vector<int> ids = participating_views(scene, o.training_views_only);
  if (ids.size() < 2) {
    fail(scene.root, "triangulation needs at least two views with known poses; " + std::to_string(ids.size()) +
                         (o.training_views_only ? " training view" : " view") + (ids.size() == 1 ? "" : "s") + " here");
  }
  TriangulatedPoints result;
  CorrespondenceSet matches;
  if (o.database.empty()) {
    MatchOptions m = o.match;
    m.training_views_only = o.training_views_only;
    m.pairs = overlapping_view_pairs(scene, ids, o.neighbours);
    if (m.pairs.empty()) fail(scene.root, "no two views look the same way (optical axes within 90 degrees): nothing to match");
    result.matches_from = "sift";
    matches = correspondences_from_matching(scene, m);
  } else {
    result.matches_from = o.database;
    matches = correspondences_from_database(scene, o.database, o.match.min_inliers, o.training_views_only);
  }
  TriangulationStats& s = result.stats;
  s.views = ids.size();
  s.pairs = matches.pairs.size();
  for (const auto& p : matches.pairs) s.matches += p.xi.size();

  std::vector<Track> tracks = tracks_from_matches(matches);
  s.tracks = tracks.size();
  std::vector<Camera> cameras;
  for (const auto& v : scene.views) cameras.push_back(v.camera);

  RobustTriangulationOptions ro;
  ro.max_error_px = o.max_error_px;
  ro.min_angle_deg = o.min_angle_deg;
  std::vector<RobustPoint> solved(tracks.size());
  std::vector<char> status(tracks.size(), 0);  // 0 kept, 1 too short, 2 inconsistent
  Progress progress("triangulate", static_cast<long>(tracks.size()), 2.0);
#pragma omp parallel for schedule(dynamic, 64)
  for (long t = 0; t < static_cast<long>(tracks.size()); ++t) {
    const auto& obs = tracks[static_cast<size_t>(t)].observations;
    std::vector<int> views;
    for (const auto& ob : obs) views.push_back(ob.view);
    std::sort(views.begin(), views.end());
    if (std::unique(views.begin(), views.end()) - views.begin() < o.min_track_length) {
      status[static_cast<size_t>(t)] = 1;
      continue;
    }
    RobustTriangulationOptions rt = ro;
    rt.seed = o.seed ^ (static_cast<uint64_t>(t) * 0x9E3779B97F4A7C15ull);  // per track: any thread order gives the same points
    RobustPoint& p = solved[static_cast<size_t>(t)];
    if (!triangulate_robust(cameras, obs, rt, &p)) {
      status[static_cast<size_t>(t)] = 2;
    } else if (static_cast<int>(p.inliers.size()) < o.min_track_length) {
      status[static_cast<size_t>(t)] = 1;
    } else if (p.angle_deg < o.min_angle_deg) {
      status[static_cast<size_t>(t)] = 2;
    }
  }
  progress.update(static_cast<long>(tracks.size()));

  // Colours: each view's image is decoded once, and adds its pixels to the points it observes.
  std::vector<std::vector<std::pair<size_t, Eigen::Vector2d>>> seen_in(scene.views.size());
  std::vector<double> errors, angles;
  double length_sum = 0;
  for (size_t t = 0; t < tracks.size(); ++t) {
    if (status[t] == 1) ++s.too_short;
    if (status[t] == 2) ++s.inconsistent;
    if (status[t] != 0) continue;
    const RobustPoint& p = solved[t];
    TriangulatedPoint tp;
    tp.xyz = p.xyz;
    tp.error_px = p.mean_error_px;
    tp.track_length = static_cast<int>(p.inliers.size());
    tp.angle_deg = p.angle_deg;
    for (const auto& ob : p.inliers) {
      seen_in[static_cast<size_t>(ob.view)].emplace_back(result.points.size(), ob.pixel);
      errors.push_back(reprojection_error(cameras[static_cast<size_t>(ob.view)], p.xyz, ob.pixel));
    }
    angles.push_back(p.angle_deg);
    length_sum += tp.track_length;
    result.points.push_back(tp);
  }
  s.points = result.points.size();
  if (result.points.empty()) {
    fail(o.database.empty() ? scene.root : o.database,
         "no point survived triangulation: " + std::to_string(s.tracks) + " tracks from " + std::to_string(s.matches) +
             " matches in " + std::to_string(s.pairs) + " view pairs; " + std::to_string(s.too_short) +
             " seen in fewer than " + std::to_string(o.min_track_length) + " views, " + std::to_string(s.inconsistent) +
             " without two observations that agree within " + std::to_string(o.max_error_px) + " px under at least " +
             std::to_string(o.min_angle_deg) + " degrees (cameras too close together for their distance to the scene?)");
  }
  for (size_t v = 0; v < seen_in.size(); ++v) {
    if (seen_in[v].empty()) continue;
    cv::Mat image = scene.load_image_u8(static_cast<int>(v));
    for (const auto& [k, pixel] : seen_in[v]) result.points[k].rgb += sample_rgb(image, pixel);
  }
  for (auto& p : result.points) p.rgb /= static_cast<float>(p.track_length);
  double sum = 0;
  for (double e : errors) sum += e;
  s.mean_error_px = sum / errors.size();
  s.median_error_px = median(errors);
  s.mean_track_length = length_sum / result.points.size();
  s.median_angle_deg = median(angles);
  return result;
}

TriangulationOptions few_shot_triangulation(int few_shot_views, TriangulationOptions options) {
  if (few_shot_views > 0 && options.training_views_only) options.min_track_length = 2;
  return options;
}

std::vector<SfmPoint> to_sfm_points(const std::vector<TriangulatedPoint>& points) {
  std::vector<SfmPoint> out;
  out.reserve(points.size());
  for (size_t k = 0; k < points.size(); ++k) out.push_back({points[k].xyz, points[k].rgb, static_cast<int64_t>(k + 1)});
  return out;
}

}  // namespace lrf
