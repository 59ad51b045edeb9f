#include <filesystem>

#include "lrf/core/atomic_file.h"
#include "lrf/core/error.h"
#include "lrf/core/image_io.h"
#include "lrf/scene/nerf_reader.h"
#include "lrf/scene/transforms_json.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

std::string resolve_image(const std::string& root, const std::string& base_dir, std::string rel,
                          const std::string& json_path) {
  if (rel.rfind("./", 0) == 0) rel = rel.substr(2);
  fs::path p = fs::path(base_dir) / rel;
  // A scene is its folder: lrf reads nothing outside it on a file's say-so (a link inside it is the
  // user's own choice and is followed).
  const fs::path normal = p.lexically_normal();
  if (normal.is_absolute() || (!normal.empty() && *normal.begin() == ".."))
    fail(json_path, "file_path '" + rel + "' leads outside the scene folder " + root +
                        "; a scene's images must lie inside it (move them in, or link their folder in)");
  if (!p.has_extension() || !fs::exists(fs::path(root) / p)) {
    // The NeRF synthetic scenes list "./train/r_0" without the extension.
    for (const char* ext : {".png", ".jpg", ".jpeg", ".JPG", ".PNG"}) {
      fs::path q = p;
      q += ext;
      if (fs::exists(fs::path(root) / q)) return q.lexically_normal().string();
    }
  }
  if (!fs::exists(fs::path(root) / p)) fail(json_path, "image '" + rel + "' not found under " + root);
  return p.lexically_normal().string();
}

void read_transforms(const std::string& root, const std::string& file, RawScene* raw, std::vector<std::string>* names) {
  const std::string path = (fs::path(root) / file).string();
  TransformsImages images;
  images.resolve = [&](const std::string& rel) { return resolve_image(root, "", rel, path); };
  images.size = [&](const std::string& rel) { return read_image_size((fs::path(root) / rel).string()); };
  parse_transforms(read_file(path), path, images, raw, names);
}

}  // namespace

RawScene read_nerf_scene(const std::string& root) {
  RawScene raw;
  raw.format = "nerf";
  if (fs::exists(fs::path(root) / "transforms.json")) {
    read_transforms(root, "transforms.json", &raw, nullptr);
  } else {
    // NeRF synthetic layout: the split is given by the files.
    read_transforms(root, "transforms_train.json", &raw, nullptr);
    if (fs::exists(fs::path(root) / "transforms_test.json")) {
      read_transforms(root, "transforms_test.json", &raw, &raw.predefined_test);
    }
  }
  // The images folder is the common first path component of the frames' files (usually "images").
  raw.images_dir = common_images_dir(raw.views);
  return raw;
}

}  // namespace lrf
