// Rasterizer timings per stage (projection, SH of every visible Gaussian, binning/sort, forward incl. the
// lazily evaluated colours render() uses, backward) for the two cases of
// issue 3, with 1 and 2 threads, plus the full render()+backward through torch autograd, render FPS and the
// training loss at each case's size.
//   (a) 63×47 px, C = 32, 50k Gaussians (latent resolution of fern images_8 with TAEF2), SH degree 0/1/3
//   (b) 504×378 px, C = 3, 100k Gaussians (RGB at images_8), SH degree 0/1/3
// Scenes: Gaussians spread through the view frustum at depths 2–8 with projected sizes log-uniform over a
// few pixels and logits uniform in [−2, 4] (a mix of faint and opaque splats, as a trained field has).
// Usage: bench_rasterizer [reps] [max threads] [a|a3|b|fps|loss|""] [vector width 1|4|8, default the widest]
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "lrf/core/allocator.h"
#include "lrf/splat/raster/binning.h"
#include "lrf/splat/train/loss.h"
#include "lrf/splat/raster/projection.h"
#include "lrf/splat/raster/raster_kernels.h"
#include "lrf/splat/raster/rasterize.h"
#include "lrf/splat/raster/sh.h"

using namespace lrf::splat;

namespace {

struct BenchScene {
  torch::Tensor means, log_scales, quats, logits, sh;
  RasterSettings settings;
};

BenchScene make_scene(int width, int height, int64_t n, int channels, int degree, double min_px, double max_px) {
  torch::manual_seed(0);
  BenchScene s;
  RasterSettings& r = s.settings;
  r.width = width, r.height = height;
  r.fx = r.fy = 0.85 * width;
  r.cx = width / 2.0, r.cy = height / 2.0;
  r.sh_degree = degree;
  r.background = torch::zeros({channels});
  auto z = torch::rand({n}, torch::kFloat64) * 6 + 2;
  auto x = (torch::rand({n}, torch::kFloat64) - 0.5) * (1.2 * width / r.fx) * z;
  auto y = (torch::rand({n}, torch::kFloat64) - 0.5) * (1.2 * height / r.fy) * z;
  s.means = torch::stack({x, y, z}, 1).to(torch::kFloat32);
  // Projected size σ_px = fx·scale/z, log-uniform in [min_px, max_px], with anisotropy up to 3×.
  auto px = torch::exp(torch::rand({n}, torch::kFloat64) * std::log(max_px / min_px) + std::log(min_px));
  auto base = torch::log(px * z / r.fx);
  s.log_scales = (base.unsqueeze(1) + (torch::rand({n, 3}, torch::kFloat64) - 0.5) * 1.1).to(torch::kFloat32);
  s.quats = torch::randn({n, 4});
  s.logits = torch::rand({n, 1}) * 6 - 2;
  s.sh = torch::randn({n, (degree + 1) * (degree + 1), channels}) * 0.2;
  return s;
}

// Wall time, or with LRF_BENCH_CPU_TIME=1 the process CPU time (all threads): on a shared, overloaded
// machine wall time measures the other jobs; CPU time of a 1-thread run does not.
bool use_cpu_time() {
  const char* e = std::getenv("LRF_BENCH_CPU_TIME");
  return e && e[0] == '1';
}
double now_ms() {
  if (use_cpu_time()) {
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
  }
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double median_ms(int reps, const std::function<void()>& fn) {
  std::vector<double> t;
  fn();  // warm-up
  for (int i = 0; i < reps; ++i) {
    const double a = now_ms();
    fn();
    t.push_back(now_ms() - a);
  }
  std::sort(t.begin(), t.end());
  return t.front();  // the minimum: on a shared machine the least-disturbed run
}

void bench_case(const char* name, int width, int height, int64_t n, int C, int degree, double min_px,
                double max_px, int threads, int reps) {
  omp_set_num_threads(threads);
  at::set_num_threads(threads);
  BenchScene s = make_scene(width, height, n, C, degree, min_px, max_px);
  Viewpoint v;
  v.width = width, v.height = height;
  v.fx = s.settings.fx, v.fy = s.settings.fy, v.cx = s.settings.cx, v.cy = s.settings.cy;
  const int K = (degree + 1) * (degree + 1);
  std::vector<float> xy(2 * n), depth(n), conic(3 * n), opacity(n), extent(2 * n), colors(n * C);
  std::vector<int32_t> radii(n), rect(4 * n);
  Projected proj{xy.data(), depth.data(), conic.data(), opacity.data(), extent.data(), radii.data(), rect.data()};
  const float *means = s.means.data_ptr<float>(), *ls = s.log_scales.data_ptr<float>(),
              *q = s.quats.data_ptr<float>(), *lo = s.logits.data_ptr<float>(), *sh = s.sh.data_ptr<float>();
  const double t_proj = median_ms(reps, [&] { project_forward(n, means, ls, q, lo, v, proj); });
  const double t_sh = median_ms(reps, [&] { sh_forward(n, K, C, degree, sh, means, v.campos, radii.data(), colors.data()); });
  TileBins bins;
  const double t_bin = median_ms(reps, [&] { bins = bin_gaussians(n, depth.data(), rect.data(), v.tiles_x(), v.tiles_y()); });
  std::vector<float> bg(C, 0.f), image(C * width * height), alpha(width * height), dimg(width * height),
      tfinal(width * height);
  std::vector<int32_t> last(width * height);
  RasterInputs in;
  in.width = width, in.height = height, in.tiles_x = v.tiles_x(), in.tiles_y = v.tiles_y(), in.channels = C;
  in.xy = xy.data(), in.conic = conic.data(), in.opacity = opacity.data(), in.extent = extent.data();
  in.depth = depth.data(), in.colors = colors.data(), in.background = bg.data();
  in.tile_offsets = bins.offsets.data(), in.tile_ids = bins.ids.data();
  // The forward evaluates colours lazily (only for splats it blends): time it with that, as render() runs it.
  struct Ctx {
    int K, C, degree;
    const float *sh, *means;
    const double* campos;
  } ctx{K, C, degree, sh, means, v.campos};
  std::vector<uint8_t> state(n);
  auto eval = [](const void* c, int64_t g, float* out) {
    const auto* x = static_cast<const Ctx*>(c);
    sh_forward_one(g, x->K, x->C, x->degree, x->sh, x->means, x->campos, out);
  };
  const double t_fwd = median_ms(reps, [&] {
    std::fill(state.begin(), state.end(), 0);
    rasterize_forward(in, {colors.data(), state.data(), eval, &ctx},
                      {image.data(), alpha.data(), dimg.data(), tfinal.data(), last.data()});
  });
  std::vector<float> d_image(C * width * height);
  for (size_t i = 0; i < d_image.size(); ++i) d_image[i] = ((i * 2654435761u) % 1000) / 1000.f - 0.5f;
  std::vector<float> g_xy(2 * n), g_conic(3 * n), g_op(n), g_z(n), g_col(n * C);
  const double t_bwd = median_ms(reps, [&] {
    rasterize_backward(n, in, {tfinal.data(), last.data(), d_image.data(), nullptr, nullptr},
                       {g_xy.data(), g_conic.data(), g_op.data(), g_z.data(), g_col.data(), true});
  });
  std::vector<float> d_means(3 * n), d_ls(3 * n), d_q(4 * n), d_lo(n), d_sh(n * K * C);
  const double t_proj_b = median_ms(reps, [&] {
    project_backward(n, means, ls, q, lo, radii.data(), v, {g_xy.data(), g_conic.data(), g_op.data(), g_z.data()},
                     d_means.data(), d_ls.data(), d_q.data(), d_lo.data());
  });
  const double t_sh_b = median_ms(reps, [&] {
    sh_backward(n, K, C, degree, sh, means, v.campos, radii.data(), colors.data(), g_col.data(), d_sh.data(),
                d_means.data(), state.data());
  });
  // The whole thing through the public API and torch autograd (allocations and wrapping included).
  std::vector<torch::Tensor> leaves = {s.means, s.log_scales, s.quats, s.logits, s.sh};
  for (auto& l : leaves) l = l.clone().requires_grad_(true);
  auto weights = torch::randn({C, height, width});
  const double t_total = median_ms(reps, [&] {
    auto out = render(leaves[0], leaves[1], leaves[2], leaves[3], leaves[4], s.settings);
    (out.image * weights).sum().backward();
    for (auto& l : leaves) l.mutable_grad().reset();
  });
  int64_t visible = 0;
  for (int32_t r : radii) visible += r > 0;
  std::printf("%-4s %4dx%-4d C=%-2d N=%-6ld deg=%d thr=%d | proj %6.2f  bin %6.2f  fwd+sh %7.2f  bwd %7.2f"
              "  proj_b %6.2f  sh_b %6.2f | sum %7.2f  render+backward %7.2f ms | (sh of all %6.2f) visible %ld, "
              "%.1f entries/tile\n",
              name, width, height, C, static_cast<long>(n), degree, threads, t_proj, t_bin, t_fwd, t_bwd, t_proj_b,
              t_sh_b, t_proj + t_bin + t_fwd + t_bwd + t_proj_b + t_sh_b, t_total, t_sh, static_cast<long>(visible), double(bins.ids.size()) / (in.tiles_x * in.tiles_y));
  std::fflush(stdout);
}

void bench_fps(int threads, int reps) {
  omp_set_num_threads(threads);
  at::set_num_threads(threads);
  BenchScene s = make_scene(504, 378, 100000, 3, 3, 0.7, 8.0);
  torch::NoGradGuard ng;
  const double ms = median_ms(reps, [&] { render(s.means, s.log_scales, s.quats, s.logits, s.sh, s.settings); });
  std::printf("render 504x378 C=3 N=100000 deg=3 thr=%d: %.2f ms = %.1f FPS\n", threads, ms, 1000.0 / ms);
}

// The training loss (0.8·L1 + 0.2·(1 − SSIM)) at a case's image size: forward alone, and forward + backward,
// so that a training step's backward can be split into the loss's part and the rasterizer's.
void bench_loss(const char* name, int width, int height, int C, int threads, int reps) {
  omp_set_num_threads(threads);
  at::set_num_threads(threads);
  torch::manual_seed(0);
  const auto target = torch::rand({C, height, width});
  const auto image = torch::rand({C, height, width}).requires_grad_(true);
  double t_fwd = 0, t_both = 0;
  {
    torch::NoGradGuard ng;
    t_fwd = median_ms(reps, [&] { photometric_loss(image, target).item<double>(); });
  }
  t_both = median_ms(reps, [&] {
    image.mutable_grad() = torch::Tensor();
    photometric_loss(image, target).backward();
  });
  std::printf("%-4s %4dx%-4d C=%-2d loss thr=%d | forward %6.2f  forward+backward %6.2f  (backward %6.2f) ms\n", name,
              width, height, C, threads, t_fwd, t_both, t_both - t_fwd);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  lrf::keep_freed_memory();  // as the lrf binary does, so that the figures match its runs
  const int reps = argc > 1 ? std::atoi(argv[1]) : 7;
  const int max_threads = argc > 2 ? std::atoi(argv[2]) : 2;
  const std::string only = argc > 3 ? argv[3] : "";  // "a", "b" or "fps" to run one part
  if (argc > 4 && !lrf::splat::set_raster_vector_width(std::atoi(argv[4]))) {
    std::fprintf(stderr, "vector width %s is not available on this CPU\n", argv[4]);
    return 2;
  }
  if (!only.empty()) {
    for (int threads = 1; threads <= max_threads; ++threads) {
      if (only == "a") bench_case("(a)", 63, 47, 50000, 32, 1, 0.3, 3.0, threads, reps);
      if (only == "a3") bench_case("(a)", 63, 47, 50000, 32, 3, 0.3, 3.0, threads, reps);
      if (only == "b") bench_case("(b)", 504, 378, 100000, 3, 1, 0.7, 8.0, threads, reps);
      if (only == "fps") bench_fps(threads, reps);
      if (only == "loss") {
        bench_loss("(a)", 63, 47, 32, threads, reps);
        bench_loss("(b)", 504, 378, 3, threads, reps);
      }
    }
    return 0;
  }
  std::printf("times in ms (%s), minimum of %d runs, compositing %d pixels at a time\n",
              use_cpu_time() ? "process CPU time" : "wall clock", reps, lrf::splat::raster_vector_width());
  for (int threads = 1; threads <= max_threads; ++threads) {
    for (int degree : {0, 1, 3}) bench_case("(a)", 63, 47, 50000, 32, degree, 0.3, 3.0, threads, reps);
    for (int degree : {0, 1, 3}) bench_case("(b)", 504, 378, 100000, 3, degree, 0.7, 8.0, threads, reps);
    bench_fps(threads, reps);
    bench_loss("(a)", 63, 47, 32, threads, reps);
    bench_loss("(b)", 504, 378, 3, threads, reps);
  }
  return 0;
}
