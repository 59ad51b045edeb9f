#include "harness.h"

#include <stdexcept>

#include "lrf/align/correspondences.h"
#include "lrf/core/error.h"
#include "lrf/core/npy.h"
#include "lrf/scene/colmap_model.h"

namespace lrf::fuzz {
namespace {

// The first byte picks which of the three COLMAP files the rest is parsed as.
void colmap(const std::string& bytes, bool text) {
  if (bytes.empty()) return;
  std::string body = bytes.substr(1);
  switch (static_cast<unsigned char>(bytes[0]) % 3) {
    case 0:
      for (const auto& [id, cam] : parse_colmap_cameras(body, "fuzz", text)) {
        double fx, fy, cx, cy;
        Distortion d;
        try {
          colmap_intrinsics(cam, "fuzz", &fx, &fy, &cx, &cy, &d);
        } catch (const Error&) {
        }
      }
      break;
    case 1:
      parse_colmap_images(body, "fuzz", text);
      break;
    default:
      parse_colmap_points(body, "fuzz", text);
  }
}

}  // namespace

const std::vector<std::string>& target_names() {
  static const std::vector<std::string> names = {"colmap_bin", "colmap_txt", "npy", "correspondences"};
  return names;
}

int run_target(const std::string& target, const uint8_t* data, size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    if (target == "colmap_bin") {
      colmap(bytes, false);
    } else if (target == "colmap_txt") {
      colmap(bytes, true);
    } else if (target == "npy") {
      parse_npy(bytes, "fuzz");
    } else if (target == "correspondences") {
      parse_correspondences(bytes, "fuzz");
    } else {
      throw std::logic_error("unknown fuzz target " + target);
    }
  } catch (const Error&) {
    // A clean, reported refusal is the expected outcome for bad input.
  }
  return 0;
}

}  // namespace lrf::fuzz
