// Rasterizer timings on a trained field rather than a synthetic one: a run's point_cloud.ply rendered
// from its scene's training views, forward alone and forward + backward through torch autograd (with an
// L1 loss against the view's image, so that the backward sees a real gradient). Trained fields differ
// from the synthetic scenes of bench_rasterizer where it matters for speed: opaque surfaces saturate
// pixels early, and splat sizes follow the scene.
// A latent field (C != 3) is rendered at its latent grid (the image cropped to a multiple of 8, then /8)
// against a target of zeros, since the training latents need the autoencoder; the gradient it sends
// back is as dense as a real L1's.
//
// usage: bench_field PLY SCENE [--images DIR] [--views N] [--reps N] [--threads N] [--width 1|4|8]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "lrf/core/allocator.h"
#include "lrf/core/threads.h"
#include "lrf/latent/latent_field.h"
#include "lrf/scene/scene.h"
#include "lrf/splat/ply_io.h"
#include "lrf/splat/raster/raster_kernels.h"
#include "lrf/splat/raster/rasterize.h"

namespace {

using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

torch::Tensor chw(const cv::Mat& rgb) {
  auto t = torch::from_blob(rgb.data, {rgb.rows, rgb.cols, 3}, torch::kFloat32);
  return t.permute({2, 0, 1}).contiguous();
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_field PLY SCENE [--images DIR] [--views N] [--reps N] [--threads N] [--width 1|4|8]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  lrf::keep_freed_memory();  // as the lrf binary does
  if (argc < 3) return usage();
  const std::string ply = argv[1], scene_dir = argv[2];
  lrf::SceneOptions options;
  options.images_dir = "images_8";
  int views = 4, reps = 5, threads = 2;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage();
    if (a == "--images") options.images_dir = argv[++i];
    else if (a == "--views") views = std::atoi(argv[++i]);
    else if (a == "--reps") reps = std::max(1, std::atoi(argv[++i]));
    else if (a == "--threads") threads = std::atoi(argv[++i]);
    else if (a == "--width") {
      if (!lrf::splat::set_raster_vector_width(std::atoi(argv[++i]))) {
        std::fprintf(stderr, "vector width %s is not available on this CPU\n", argv[i]);
        return 2;
      }
    } else {
      return usage();
    }
  }
  try {
    lrf::set_thread_count(threads);
    lrf::splat::Gaussians g = lrf::splat::read_ply(ply);
    const bool latent = g.channels() != 3;
    options.crop_to_multiple_of_8 = latent;
    const lrf::Scene scene = lrf::load_scene(scene_dir, options);
    const int degree = g.max_sh_degree;
    g.make_leaves();
    std::printf("%s: %lld Gaussians, SH degree %d, %d threads, %d lanes; median of %d runs per view\n",
                ply.c_str(), static_cast<long long>(g.size()), degree, threads,
                lrf::splat::raster_vector_width(), reps);
    double sum_fwd = 0, sum_both = 0;
    const int n_views = std::min<int>(views, static_cast<int>(scene.train_indices.size()));
    for (int k = 0; k < n_views; ++k) {
      const lrf::View& view = scene.views[static_cast<size_t>(scene.train_indices[static_cast<size_t>(k)])];
      const lrf::Camera camera = latent ? lrf::latent_camera(view.camera) : view.camera;
      const torch::Tensor target =
          latent ? torch::zeros({g.channels(), camera.height, camera.width})
                 : chw(scene.load_image(scene.train_indices[static_cast<size_t>(k)]));
      const auto settings = lrf::splat::settings_for(camera, degree, torch::zeros({g.channels()}));
      std::vector<double> fwd, both;
      for (int r = 0; r < reps; ++r) {
        auto t0 = Clock::now();
        {
          torch::NoGradGuard no_grad;
          lrf::splat::render(g.means, g.log_scales, g.quats, g.opacity_logits, g.sh, settings);
        }
        fwd.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        t0 = Clock::now();
        auto out = lrf::splat::render(g.means, g.log_scales, g.quats, g.opacity_logits, g.sh, settings);
        (out.image - target).abs().mean().backward();
        both.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        for (auto* p : g.parameters()) p->mutable_grad() = torch::Tensor();
      }
      std::printf("  %-16s %dx%d  render %7.2f ms  render+backward %7.2f ms\n", view.name.c_str(),
                  camera.width, camera.height, median(fwd), median(both));
      sum_fwd += median(fwd);
      sum_both += median(both);
    }
    std::printf("mean over %d views: render %.2f ms, render+backward %.2f ms\n", n_views, sum_fwd / n_views,
                sum_both / n_views);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_field: %s\n", e.what());
    return 1;
  }
  return 0;
}
