#pragma once
// Reading the frames of a transforms.json, apart from the file system so that a fuzzer can drive it.
#include <string>
#include <functional>
#include <vector>

#include <opencv2/core/types.hpp>

#include "lrf/scene/raw_scene.h"

namespace lrf {

// The file-system side of reading a transforms.json: `resolve` maps a frame's "file_path" (without a
// leading "./", never empty) to the image path relative to the scene root, throwing lrf::Error if there is
// none; `size` gives an image's size when neither the frame nor the file states "w" and "h".
struct TransformsImages {
  std::function<std::string(const std::string& file_path)> resolve;
  std::function<cv::Size(const std::string& image_rel)> size;
};
// Appends the frames of a transforms.json (NeRF synthetic, instant-ngp, nerfstudio) given as text
// (`path` names it in errors) to raw->views, and their names to *names when given.
void parse_transforms(const std::string& text, const std::string& path, const TransformsImages& images,
                      RawScene* raw, std::vector<std::string>* names);
// The images folder of a NeRF scene: the common first path component of the views' files ("" if none).
std::string common_images_dir(const std::vector<RawView>& views);

}  // namespace lrf
