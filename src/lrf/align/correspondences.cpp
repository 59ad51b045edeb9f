#include "lrf/align/correspondences.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <unordered_map>

#include "lrf/core/error.h"

namespace lrf {
namespace {

std::vector<bool> usable_views(const Scene& scene, bool training_only) {
  std::vector<bool> ok(scene.views.size(), !training_only);
  if (training_only) {
    for (int i : scene.train_indices) ok[i] = true;
  }
  return ok;
}

bool inside(const Camera& c, const Eigen::Vector2d& p) {
  return p.x() >= 0 && p.y() >= 0 && p.x() < c.width && p.y() < c.height;
}

}  // namespace

CorrespondenceSet empty_correspondences(const Scene& scene, const std::string& source) {
  CorrespondenceSet set;
  set.scene = scene.root;
  set.source = source;
  for (const auto& v : scene.views) {
    set.view_names.push_back(v.name);
    set.widths.push_back(v.camera.width);
    set.heights.push_back(v.camera.height);
  }
  return set;
}

CorrespondenceSet correspondences_from_tracks(const Scene& scene, int min_matches, bool training_only) {
  if (!scene.has_tracks) fail(scene.root, "scene has no COLMAP tracks (images.bin 2D points with 3D point ids)");
  CorrespondenceSet set = empty_correspondences(scene, "tracks");
  auto ok = usable_views(scene, training_only);
  // point id -> observations (view, pixel), one per view (COLMAP can observe a point twice in an image
  // only through duplicate keypoints; keep the first).
  std::unordered_map<int64_t, std::vector<std::pair<int, Eigen::Vector2d>>> tracks;
  for (int v = 0; v < static_cast<int>(scene.views.size()); ++v) {
    if (!ok[v]) continue;
    std::set<int64_t> seen;
    for (const auto& ob : scene.views[v].observations) {
      if (!inside(scene.views[v].camera, ob.pixel) || !seen.insert(ob.point_id).second) continue;
      tracks[ob.point_id].emplace_back(v, ob.pixel);
    }
  }
  std::map<std::pair<int, int>, ViewPairMatches> pairs;
  for (const auto& [id, obs] : tracks) {
    for (size_t a = 0; a < obs.size(); ++a) {
      for (size_t b = a + 1; b < obs.size(); ++b) {
        auto [i, pi] = obs[a];
        auto [j, pj] = obs[b];
        if (i > j) std::swap(i, j), std::swap(pi, pj);
        auto& m = pairs[{i, j}];
        m.view_i = i;
        m.view_j = j;
        m.xi.push_back(pi.cast<float>());
        m.xj.push_back(pj.cast<float>());
      }
    }
  }
  for (auto& [key, m] : pairs) {
    if (static_cast<int>(m.xi.size()) >= min_matches) set.pairs.push_back(std::move(m));
  }
  if (set.pairs.empty()) fail(scene.root, "no view pair shares at least " + std::to_string(min_matches) + " tracked points");
  return set;
}

std::vector<std::pair<int, int>> sequential_pairs(int views, int overlap, int quadratic_overlap) {
  std::set<std::pair<int, int>> pairs;
  for (int i = 0; i < views; ++i) {
    for (int j = i + 1; j <= i + overlap && j < views; ++j) pairs.insert({i, j});
    if (quadratic_overlap) {
      for (int k = 0; k < overlap && k < 30; ++k) {
        long j = i + (1L << k);
        if (j < views) pairs.insert({i, static_cast<int>(j)});
      }
    }
  }
  return {pairs.begin(), pairs.end()};
}

double epipolar_distance(const Camera& ci, const Camera& cj, const Eigen::Vector2d& xi, const Eigen::Vector2d& xj) {
  Eigen::Matrix3d R = cj.R * ci.R.transpose();
  Eigen::Vector3d t = cj.t - R * ci.t;
  Eigen::Matrix3d tx;
  tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  Eigen::Matrix3d F = cj.K().inverse().transpose() * tx * R * ci.K().inverse();
  Eigen::Vector3d l = F * Eigen::Vector3d(xi.x(), xi.y(), 1);
  double n = std::hypot(l.x(), l.y());
  return n > 0 ? std::abs(Eigen::Vector3d(xj.x(), xj.y(), 1).dot(l)) / n : 0.0;
}

CorrespondenceSummary summarize(const CorrespondenceSet& set, const Scene& scene) {
  CorrespondenceSummary s;
  s.pairs = set.pairs.size();
  std::vector<double> per_pair, epi;
  for (const auto& p : set.pairs) {
    per_pair.push_back(static_cast<double>(p.xi.size()));
    s.matches += p.xi.size();
    const Camera& ci = scene.views.at(p.view_i).camera;
    const Camera& cj = scene.views.at(p.view_j).camera;
    for (size_t k = 0; k < p.xi.size(); ++k) {
      Eigen::Vector2d a = p.xi[k].cast<double>(), b = p.xj[k].cast<double>();
      epi.push_back(0.5 * (epipolar_distance(ci, cj, a, b) + epipolar_distance(cj, ci, b, a)));
    }
  }
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  if (!per_pair.empty()) {
    s.matches_per_pair_mean = double(s.matches) / per_pair.size();
    s.matches_per_pair_median = median(per_pair);
  }
  if (!epi.empty()) {
    double sum = 0;
    for (double e : epi) sum += e;
    s.epipolar_mean_px = sum / epi.size();
    s.epipolar_median_px = median(epi);
  }
  return s;
}

}  // namespace lrf
