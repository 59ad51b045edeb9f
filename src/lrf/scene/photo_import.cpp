#include "lrf/scene/photo_import.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/scene/raw_scene.h"

namespace fs = std::filesystem;

namespace lrf {

std::vector<std::string> list_photos(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) fail(dir, "photos folder not found");
  if (!fs::is_directory(dir, ec)) fail(dir, "not a folder (give the folder that holds the photos)");
  std::vector<std::string> names = list_images(dir);
  if (names.empty()) {
    fail(dir, "no photos in this folder (looked for .jpg, .jpeg, .png, .bmp, .tif, .tiff, .webp files directly "
              "inside it, not in subfolders)");
  }
  return names;
}

std::vector<PreparedPhoto> prepare_photos(const std::string& from_dir, const std::vector<std::string>& names,
                                          const std::string& to_dir, int max_side) {
  fs::create_directories(to_dir);
  std::vector<PreparedPhoto> out;
  for (const auto& name : names) {
    const std::string from = (fs::path(from_dir) / name).string();
    // IMREAD_COLOR applies the EXIF orientation: a portrait phone photo stays portrait in the scene.
    cv::Mat image = cv::imread(from, cv::IMREAD_COLOR);
    if (image.empty()) fail(from, "cannot decode this photo (corrupt or an unsupported format)");
    const int longer = std::max(image.cols, image.rows);
    if (max_side > 0 && longer > max_side) {
      const double scale = double(max_side) / longer;
      cv::Mat small;
      cv::resize(image, small,
                 cv::Size(std::max(1, static_cast<int>(std::lround(image.cols * scale))),
                          std::max(1, static_cast<int>(std::lround(image.rows * scale)))),
                 0, 0, cv::INTER_AREA);
      image = small;
    }
    // Re-encoded even at full size, so that every photo COLMAP sees is upright like the ones lrf decodes.
    // That drops the EXIF focal length: COLMAP then starts from its default guess and refines the focal
    // length in bundle adjustment.
    const std::string to = (fs::path(to_dir) / name).string();
    const std::vector<int> params = {cv::IMWRITE_JPEG_QUALITY, 95};
    if (!cv::imwrite(to, image, params)) fail(to, "cannot write the prepared photo");
    out.push_back({name, image.cols, image.rows});
  }
  return out;
}

void write_photo_sizes(const std::string& path, const std::vector<PreparedPhoto>& photos) {
  std::ostringstream s;
  for (const auto& p : photos) s << p.name << "\t" << p.width << "\t" << p.height << "\n";
  write_file_atomic(path, s.str());
}

std::vector<PreparedPhoto> read_photo_sizes(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail(path, "cannot read the prepared photos' sizes");
  std::vector<PreparedPhoto> out;
  std::string line;
  while (std::getline(in, line)) {
    const size_t a = line.find('\t'), b = line.rfind('\t');
    if (a == std::string::npos || a == b) fail(path, "malformed line '" + line + "'");
    PreparedPhoto p;
    p.name = line.substr(0, a);
    try {
      p.width = std::stoi(line.substr(a + 1, b - a - 1));
      p.height = std::stoi(line.substr(b + 1));
    } catch (const std::exception&) {
      fail(path, "malformed line '" + line + "'");
    }
    out.push_back(p);
  }
  return out;
}

}  // namespace lrf
