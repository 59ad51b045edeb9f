#pragma once
// When COLMAP's mapper cannot start a model ("no good initial image pair"), its own output says nothing a
// photographer can act on, and a rerun repeats it. This reads what the matcher found (the database's
// verified matches per pair of photos) and says how well the photos matched, which ones matched nothing,
// and what to try.
#include <string>

namespace lrf {

// COLMAP's defaults that the report compares against: a pair counts as matched with at least this many
// verified matches (--TwoViewGeometry.min_num_inliers), and the mapper starts from a pair with at least
// kInitMinInliers (--Mapper.init_min_num_inliers, which lrf scene create --init-min-inliers sets).
constexpr int kMatchedPairMinInliers = 15;
constexpr int kInitMinInliers = 100;

// A few lines for the user: how many pairs matched, the best pairs with their match counts, the photos
// that matched no other, and what to try next. `init_min_inliers` is the threshold the mapper ran with.
// Throws lrf::Error naming the database if it cannot be read.
std::string describe_matches(const std::string& database, int init_min_inliers);

}  // namespace lrf
