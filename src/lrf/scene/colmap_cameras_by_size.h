#pragma once
// Photos of several sizes cannot share one COLMAP camera, and a camera per photo leaves each photo's lens
// distortion to be fitted from its own matches alone: on a capture of 14 photos at three sizes that gave
// distortion so wild that undistortion kept 80x60 crops of 400x300 photos. Photos of one size come from
// one camera setting in practice (a phone held one way), so they share one camera here.
#include <string>

namespace lrf {

// Rewrites the COLMAP database (after feature extraction with one camera per image) so that the images
// of each size share the first of their cameras; the others are deleted. Returns how many cameras are
// left. Throws lrf::Error naming the database if it cannot be read or written.
int share_cameras_by_image_size(const std::string& database);

}  // namespace lrf
