#pragma once
// Bounds on the images `lrf render` and `lrf eval` are asked for, checked before any work: a scale is a
// finite positive number, and an image has 1 to kMaxRenderSide pixels per side. Without them `--scale nan`
// wrote 1x1 images and exited 0, and `--width 100000 --height 100000` failed inside libtorch after 49 s.
#include <string>

namespace lrf::splat {

// 8192: twice 4K UHD's width, and 12x the longer side of the scenes lrf is measured on (640 px). The
// rasterizer holds a whole image's per-pixel state at once, so an image of this size already takes
// gigabytes on a field of a few million Gaussians.
constexpr int kMaxRenderSide = 8192;

// --scale, --width and --height as given (width and height 0: not given). Throws lrf::UsageError unless
// the scale is finite and positive, and the width and height are given together, each 1..kMaxRenderSide.
void check_render_options(double scale, int width, int height);

// The size a view of width x height renders at with --scale `scale`; throws lrf::UsageError when a side
// would be larger than kMaxRenderSide, saying which scale is the largest that fits.
void check_scaled_size(int width, int height, double scale);

}  // namespace lrf::splat
