#include "lrf/scene/colmap_match_report.h"

#include <sqlite3.h>

#include <algorithm>
#include <map>
#include <set>
#include <vector>

#include "lrf/scene/colmap_database.h"

namespace lrf {
namespace {

// COLMAP numbers a pair of images (id1 < id2) as id1 * 2^31-1 + id2.
constexpr int64_t kMaxImageId = 2147483647;

struct PairMatches {
  int64_t first, second;
  int64_t inliers;
};

std::string joined(const std::vector<std::string>& names, size_t at_most) {
  std::string out;
  for (size_t i = 0; i < names.size() && i < at_most; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > at_most) out += " and " + std::to_string(names.size() - at_most) + " more";
  return out;
}

}  // namespace

std::string describe_matches(const std::string& database, int init_min_inliers) {
  ColmapDatabase db(database, false);
  std::map<int64_t, std::string> names;
  db.each_row("SELECT image_id, name FROM images", [&](sqlite3_stmt* st) {
    const auto* name = reinterpret_cast<const char*>(sqlite3_column_text(st, 1));
    names[sqlite3_column_int64(st, 0)] = name ? name : "";
  });
  // Verified matches per pair: the rows of two_view_geometries with a model (config > 0).
  std::vector<PairMatches> pairs;
  db.each_row("SELECT pair_id, rows, config FROM two_view_geometries", [&](sqlite3_stmt* st) {
    const int64_t id = sqlite3_column_int64(st, 0);
    if (sqlite3_column_int64(st, 2) > 0) pairs.push_back({id / kMaxImageId, id % kMaxImageId, sqlite3_column_int64(st, 1)});
  });
  std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.inliers > b.inliers; });
  std::set<int64_t> matched_photos;
  int matched = 0, strong = 0;
  for (const auto& p : pairs) {
    if (p.inliers < kMatchedPairMinInliers) continue;
    ++matched;
    strong += p.inliers >= init_min_inliers;
    matched_photos.insert(p.first);
    matched_photos.insert(p.second);
  }
  const auto name_of = [&](int64_t id) {
    const auto it = names.find(id);
    return it == names.end() ? "image " + std::to_string(id) : it->second;
  };
  std::vector<std::string> alone;
  for (const auto& [id, name] : names)
    if (!matched_photos.count(id)) alone.push_back(name);
  const size_t n = names.size();
  std::string out = "What the matcher found: of the " + std::to_string(n * (n - 1) / 2) + " pairs of the " +
                    std::to_string(n) + " photos, " + std::to_string(matched) + " share at least " +
                    std::to_string(kMatchedPairMinInliers) + " verified matches, " + std::to_string(strong) +
                    " of them the " + std::to_string(init_min_inliers) + " the mapper needs to start from a pair.";
  if (!pairs.empty()) {
    std::vector<std::string> best;
    for (size_t i = 0; i < pairs.size() && i < 3; ++i)
      best.push_back(name_of(pairs[i].first) + " + " + name_of(pairs[i].second) + " (" +
                     std::to_string(pairs[i].inliers) + ")");
    out += "\nBest pairs: " + joined(best, 3) + ".";
  }
  if (strong > 0)
    out += "\nThe mapper starts from such a pair only if its two views are also far enough apart (an angle of "
           "several degrees at the points they share) and grows the model from photos that connect to it: " +
           std::string(strong <= 2 ? "with so few strong pairs, too few did." : "here too few did.");
  if (!alone.empty())
    out += "\n" + std::to_string(alone.size()) + " photo" + (alone.size() == 1 ? " matches" : "s match") +
           " no other: " + joined(alone, 8) + ".";
  out += "\nWhat to try: more photos, taken closer together (each overlapping its neighbours by about two "
         "thirds, the subject sharp and textured, no zoom changes)";
  if (!pairs.empty() && pairs.front().inliers >= kMatchedPairMinInliers && pairs.front().inliers < init_min_inliers)
    out += "; or let the mapper start from a weaker pair: --init-min-inliers " +
           std::to_string(std::max<int64_t>(kMatchedPairMinInliers * 2, pairs.front().inliers * 3 / 4));
  out += "; or keep the photos larger for more features to match (--max-side 0 keeps them as they are).";
  return out;
}

}  // namespace lrf
