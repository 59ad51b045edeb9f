#include "lrf/splat/run/render_size.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "lrf/core/error.h"

namespace lrf::splat {
namespace {

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", x);
  return text;
}

}  // namespace

void check_render_options(double scale, int width, int height) {
  if (!(std::isfinite(scale) && scale > 0)) fail_usage("--scale must be a finite positive number, got " + number(scale));
  if (width < 0 || height < 0) fail_usage("--width and --height must be positive");
  if ((width > 0) != (height > 0)) {
    fail_usage("--width and --height go together, each a positive number of pixels (got " + std::to_string(width) +
               " and " + std::to_string(height) + ")");
  }
  if (width > kMaxRenderSide || height > kMaxRenderSide) {
    fail_usage("--width " + std::to_string(width) + " --height " + std::to_string(height) + ": lrf renders at most " +
               std::to_string(kMaxRenderSide) + " pixels per side");
  }
}

void check_scaled_size(int width, int height, double scale) {
  const double w = width * scale, h = height * scale;
  if (w <= kMaxRenderSide + 0.5 && h <= kMaxRenderSide + 0.5) return;
  const double largest = kMaxRenderSide / double(std::max(width, height));
  fail_usage("--scale " + number(scale) + " would render " + number(std::round(w)) + "x" + number(std::round(h)) +
             " images of these " + std::to_string(width) + "x" + std::to_string(height) + " views; lrf renders at most " +
             std::to_string(kMaxRenderSide) + " pixels per side (--scale " + number(std::floor(largest * 100) / 100) +
             " at most here)");
}

}  // namespace lrf::splat
