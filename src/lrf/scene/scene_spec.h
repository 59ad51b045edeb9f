#pragma once
// A scene named on a command line together with the resolution it is used at, for the commands that take
// several scenes at once (`lrf pipeline`), where one --images or --downscale cannot suit every scene (LLFF
// fern is measured on images_8, flower and room at their full images halved):
//   PATH                               the scene at the command's default resolution
//   PATH:--images=DIR                  its images from the folder DIR inside the scene (e.g. images_8)
//   PATH:--downscale=N                 its images area-resized by the integer N
//   PATH:--images=DIR:--downscale=N    both
// The options are what follows the first ':--' of the argument, so a path holding ':' still works as long
// as no ':--' is in it.
#include <string>

#include <nlohmann/json.hpp>

namespace lrf {

struct SceneResolution {
  std::string images;  // image folder inside the scene; "" = the scene's default
  int downscale = 0;   // area-resize factor; 0 = the command's default (pipeline: from --max-side)

  bool is_default() const { return images.empty() && downscale == 0; }
  // The options as written after the path, "--images=images_8:--downscale=2"; "" when default.
  std::string text() const;
  // {"images": DIR or "", "downscale": N or 0}, for records and resume keys.
  nlohmann::json json() const;
};

struct SceneSpec {
  std::string path;
  SceneResolution resolution;
};

// The largest --downscale a scene may be given (the loader refuses views that end up below kMinImageSide).
constexpr int kMaxSceneDownscale = 1 << 16;

// Parses one scene argument. Throws lrf::UsageError naming the argument and what is wrong with it: no
// path, an option other than --images and --downscale, one without '=value', a bad value, an option given
// twice.
SceneSpec parse_scene_spec(const std::string& text);

// Throws lrf::Error naming the folder if the scene folder, or the image folder its --images names, does
// not exist; `argument` (the text it was parsed from) is quoted in the message.
void check_scene_spec_folders(const SceneSpec& spec, const std::string& argument);

}  // namespace lrf
