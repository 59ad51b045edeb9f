#include "lrf/points/tracks.h"

#include <algorithm>
#include <cstring>
#include <unordered_map>

namespace lrf {
namespace {

class UnionFind {
 public:
  int add() {
    parent_.push_back(static_cast<int>(parent_.size()));
    return parent_.back();
  }
  int find(int x) {
    while (parent_[static_cast<size_t>(x)] != x) {
      parent_[static_cast<size_t>(x)] = parent_[static_cast<size_t>(parent_[static_cast<size_t>(x)])];
      x = parent_[static_cast<size_t>(x)];
    }
    return x;
  }
  void join(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
  }

 private:
  std::vector<int> parent_;
};

// (view, x bits, y bits) packed for hashing.
struct KeypointKey {
  int view;
  uint32_t x, y;
  bool operator==(const KeypointKey& o) const { return view == o.view && x == o.x && y == o.y; }
};
struct KeypointHash {
  size_t operator()(const KeypointKey& k) const {
    uint64_t h = (static_cast<uint64_t>(k.x) << 32) ^ k.y;
    h ^= static_cast<uint64_t>(k.view) * 0x9E3779B97F4A7C15ull;
    h ^= h >> 29;
    return static_cast<size_t>(h * 0xBF58476D1CE4E5B9ull);
  }
};

uint32_t bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

}  // namespace

std::vector<Track> tracks_from_matches(const CorrespondenceSet& matches) {
  UnionFind sets;
  std::unordered_map<KeypointKey, int, KeypointHash> id_of;
  std::vector<PixelObservation> keypoints;
  auto id = [&](int view, const Eigen::Vector2f& p) {
    KeypointKey key{view, bits(p.x()), bits(p.y())};
    auto [it, added] = id_of.emplace(key, 0);
    if (added) {
      it->second = sets.add();
      keypoints.push_back({view, p.cast<double>()});
    }
    return it->second;
  };
  for (const auto& pair : matches.pairs) {
    for (size_t k = 0; k < pair.xi.size() && k < pair.xj.size(); ++k) sets.join(id(pair.view_i, pair.xi[k]), id(pair.view_j, pair.xj[k]));
  }
  std::unordered_map<int, size_t> track_of_root;
  std::vector<Track> tracks;
  for (int k = 0; k < static_cast<int>(keypoints.size()); ++k) {
    auto [it, added] = track_of_root.emplace(sets.find(k), tracks.size());
    if (added) tracks.emplace_back();
    tracks[it->second].observations.push_back(keypoints[static_cast<size_t>(k)]);
  }
  // Keypoints are numbered in the order the pairs list them, so this order is deterministic too.
  std::stable_sort(tracks.begin(), tracks.end(),
                   [](const Track& a, const Track& b) { return a.observations.size() > b.observations.size(); });
  return tracks;
}

}  // namespace lrf
