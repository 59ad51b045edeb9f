// lrf's own matcher: SIFT features, Lowe's ratio test both ways (mutual), RANSAC on the fundamental
// matrix, pairs kept with >= min_inliers and an inlier ratio >= min_inlier_ratio, over COLMAP-style
// sequential + quadratic pairs or the pairs the caller gives.
#include <algorithm>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "lrf/align/correspondences_matching.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/core/progress.h"

namespace lrf {
namespace {

struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
};

std::vector<cv::DMatch> ratio_matches(const cv::Mat& a, const cv::Mat& b, double ratio) {
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(a, b, knn, 2);
  std::vector<cv::DMatch> out;
  for (const auto& m : knn) {
    if (m.size() == 2 && m[0].distance < ratio * m[1].distance) out.push_back(m[0]);
  }
  return out;
}

}  // namespace

CorrespondenceSet correspondences_from_matching(const Scene& scene, const MatchOptions& o) {
  CorrespondenceSet set = empty_correspondences(scene, "match");
  std::vector<int> ids;  // views that take part, in name order
  if (o.training_views_only) {
    ids = scene.train_indices;
  } else {
    for (int i = 0; i < static_cast<int>(scene.views.size()); ++i) ids.push_back(i);
  }
  std::vector<Features> feats(ids.size());
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(o.max_features);
  Progress progress("sift", static_cast<long>(ids.size()));
  for (size_t k = 0; k < ids.size(); ++k) {
    cv::Mat gray;
    cv::cvtColor(scene.load_image_u8(ids[k]), gray, cv::COLOR_RGB2GRAY);
    sift->detectAndCompute(gray, cv::noArray(), feats[k].keypoints, feats[k].descriptors);
    progress.update(static_cast<long>(k + 1));
  }
  std::vector<std::pair<int, int>> pairs;  // positions in ids
  if (o.pairs.empty()) {
    pairs = sequential_pairs(static_cast<int>(ids.size()), o.sequential_overlap, o.quadratic_overlap);
  } else {
    std::vector<int> position(scene.views.size(), -1);
    for (size_t k = 0; k < ids.size(); ++k) position[static_cast<size_t>(ids[k])] = static_cast<int>(k);
    for (auto [i, j] : o.pairs) {
      if (i < 0 || j < 0 || i >= static_cast<int>(position.size()) || j >= static_cast<int>(position.size()) || i == j)
        fail(scene.root, "view pair (" + std::to_string(i) + ", " + std::to_string(j) + ") out of range");
      if (position[i] >= 0 && position[j] >= 0) pairs.emplace_back(std::min(position[i], position[j]), std::max(position[i], position[j]));
    }
  }
  Progress match_progress("match", static_cast<long>(pairs.size()));
  long done = 0;
  for (auto [a, b] : pairs) {
    ++done;
    const Features& fa = feats[a];
    const Features& fb = feats[b];
    if (fa.keypoints.size() < 8 || fb.keypoints.size() < 8) continue;
    auto ab = ratio_matches(fa.descriptors, fb.descriptors, o.ratio_test);
    auto ba = ratio_matches(fb.descriptors, fa.descriptors, o.ratio_test);
    std::vector<int> back(fb.keypoints.size(), -1);
    for (const auto& m : ba) back[m.queryIdx] = m.trainIdx;
    std::vector<cv::Point2f> pa, pb;
    for (const auto& m : ab) {
      if (back[m.trainIdx] != m.queryIdx) continue;  // mutual best matches only
      pa.push_back(fa.keypoints[m.queryIdx].pt);
      pb.push_back(fb.keypoints[m.trainIdx].pt);
    }
    if (static_cast<int>(pa.size()) < std::max(8, o.min_inliers)) continue;
    std::vector<uchar> mask;
    cv::Mat F = cv::findFundamentalMat(pa, pb, cv::FM_RANSAC, o.ransac_threshold_px, 0.999, mask);
    if (F.empty()) continue;
    ViewPairMatches m;
    m.view_i = ids[a];
    m.view_j = ids[b];
    for (size_t k = 0; k < pa.size(); ++k) {
      if (!mask[k]) continue;
      // OpenCV's keypoints put pixel centres at integers; lrf at +0.5.
      m.xi.emplace_back(pa[k].x + 0.5f, pa[k].y + 0.5f);
      m.xj.emplace_back(pb[k].x + 0.5f, pb[k].y + 0.5f);
    }
    double ratio = double(m.xi.size()) / pa.size();
    if (static_cast<int>(m.xi.size()) >= o.min_inliers && ratio >= o.min_inlier_ratio) set.pairs.push_back(std::move(m));
    match_progress.update(done);
  }
  if (set.pairs.empty()) fail(scene.root, "the matcher found no view pair with enough inliers");
  return set;
}

}  // namespace lrf
