#pragma once
// A user's photos as COLMAP reads them for lrf scene create: copied (never touched in place) into a work
// folder, downscaled when large.
#include <string>
#include <vector>

namespace lrf {

struct PreparedPhoto {
  std::string name;  // file name, as in the photos folder
  int width = 0, height = 0;  // after any downscale
};

// The photos of `dir` (image files directly inside it, by extension, sorted by name). Throws lrf::Error
// naming the folder when it is missing, not a folder, or holds no photo.
std::vector<std::string> list_photos(const std::string& dir);

// Writes each photo of `names` from `from_dir` to `to_dir`, upright (the EXIF orientation applied) and
// area-downscaled so that its longer side is at most `max_side` pixels (0: full size). Throws naming a
// photo that cannot be decoded or written.
std::vector<PreparedPhoto> prepare_photos(const std::string& from_dir, const std::vector<std::string>& names,
                                          const std::string& to_dir, int max_side);

// Records / reads back the prepared photos' sizes (one "name width height" line each), so that a resumed
// run decides the camera setup without decoding them again.
void write_photo_sizes(const std::string& path, const std::vector<PreparedPhoto>& photos);
std::vector<PreparedPhoto> read_photo_sizes(const std::string& path);

}  // namespace lrf
