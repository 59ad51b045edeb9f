#include "lrf/scene/scene_spec.h"

#include <filesystem>
#include <vector>

#include "lrf/core/error.h"

namespace fs = std::filesystem;

namespace lrf {
namespace {

constexpr const char* kOptionsStart = ":--";
constexpr const char* kAccepted = "a scene takes --images=DIR and --downscale=N (e.g. PATH:--images=images_8)";

[[noreturn]] void bad_spec(const std::string& text, const std::string& what) {
  fail_usage("scene '" + text + "': " + what);
}

// A whole decimal integer in [1, kMaxSceneDownscale]; std::stoi alone would accept "2x" and " 2".
int parse_downscale(const std::string& text, const std::string& value) {
  const bool digits = !value.empty() && value.size() <= 6 && value.find_first_not_of("0123456789") == std::string::npos;
  const long n = digits ? std::stol(value) : 0;
  if (n < 1 || n > kMaxSceneDownscale) {
    bad_spec(text, "--downscale '" + value + "' is not a whole number from 1 to " + std::to_string(kMaxSceneDownscale));
  }
  return static_cast<int>(n);
}

}  // namespace

std::string SceneResolution::text() const {
  std::string t;
  if (!images.empty()) t += "--images=" + images;
  if (downscale > 0) t += std::string(t.empty() ? "" : ":") + "--downscale=" + std::to_string(downscale);
  return t;
}

nlohmann::json SceneResolution::json() const { return {{"images", images}, {"downscale", downscale}}; }

SceneSpec parse_scene_spec(const std::string& text) {
  SceneSpec spec;
  const size_t start = text.find(kOptionsStart);
  spec.path = text.substr(0, start);
  if (spec.path.empty()) bad_spec(text, "no scene folder before the options");
  if (start == std::string::npos) return spec;
  // Each option runs from its "--" to the next ":--" (or the end).
  std::vector<std::string> options;
  for (size_t at = start + 1;;) {
    const size_t next = text.find(kOptionsStart, at);
    options.push_back(text.substr(at, next == std::string::npos ? std::string::npos : next - at));
    if (next == std::string::npos) break;
    at = next + 1;
  }
  bool images_given = false, downscale_given = false;
  for (const std::string& option : options) {
    const size_t eq = option.find('=');
    const std::string name = option.substr(0, eq);
    if (name != "--images" && name != "--downscale") bad_spec(text, "unknown option '" + option + "'; " + kAccepted);
    if (eq == std::string::npos) bad_spec(text, name + " needs a value (" + name + "=...)");
    const std::string value = option.substr(eq + 1);
    bool& given = name == "--images" ? images_given : downscale_given;
    if (given) bad_spec(text, name + " is given twice");
    given = true;
    if (name == "--downscale") {
      spec.resolution.downscale = parse_downscale(text, value);
    } else {
      // A folder inside the scene: one plain name, so that the scene's records name it unambiguously.
      if (value.empty() || value == "." || value == ".." || value.find('/') != std::string::npos) {
        bad_spec(text, "--images '" + value + "' is not the name of an image folder inside the scene");
      }
      spec.resolution.images = value;
    }
  }
  return spec;
}

void check_scene_spec_folders(const SceneSpec& spec, const std::string& argument) {
  if (!fs::is_directory(spec.path)) fail(spec.path, "scene folder not found (from '" + argument + "')");
  if (!spec.resolution.images.empty() && !fs::is_directory(fs::path(spec.path) / spec.resolution.images)) {
    fail((fs::path(spec.path) / spec.resolution.images).string(),
         "image folder not found (--images=" + spec.resolution.images + " of '" + argument + "')");
  }
}

}  // namespace lrf
