// Milliseconds per training iteration of the 3DGS trainer, split by phase, for the two cases of
// issue 3: (a) latent-size views (63x47, C = 32, 50k Gaussians, SH degree 0/1/3) and (b) image-size
// RGB views (504x378, C = 3, 100k and 300k Gaussians), on 1 and 2 threads; plus peak memory.
//
// Phases: render (projection + binning/sort + SH + forward compositing, inside the rasterizer), loss
// (L1 + SSIM forward), backward (loss and rasterizer backward), optimizer (fused Adam), densify
// (statistics every step; one clone/split/prune, reported separately per call). Rows "(a)sp" use the
// sparse Adam (rows no pixel reached are skipped). The rasterizer's own stages (projection, SH,
// binning/sort, forward, backward) are timed by bench_rasterizer. Case (a) starts with Adam's update loop
// alone, scalar against vectorised (their ratio, measured alternately in one run).
//
// usage: bench_train [--quick] [--case a|b|all] [--sh 0|1|3 (case (a) only that degree)] [--iters N]
//                    [--width 1|4|8 (compositing lanes; default widest)]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "lrf/core/allocator.h"
#include "lrf/core/threads.h"
#include "lrf/splat/train/densify.h"
#include "lrf/splat/train/optimizer.h"
#include "lrf/splat/raster/raster_kernels.h"
#include "lrf/splat/train/trainer.h"

using namespace lrf::splat;
using Clock = std::chrono::steady_clock;

namespace {

long vm_hwm_kb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

lrf::Camera camera(int w, int h, double yaw) {
  lrf::Camera c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = 0.8 * w;  // fern images_8 has f ~ 0.8 W
  c.cx = w / 2.0;
  c.cy = h / 2.0;
  c.R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  c.t = Eigen::Vector3d(0, 0, 0);
  return c;
}

// Gaussians filling the frustum between depth 2 and 6, sized so that neighbours overlap (as a trained
// field's do): scale ~ 1.5 x the mean spacing.
Gaussians field(int64_t n, int channels, int degree, double fov_x, double fov_y) {
  torch::manual_seed(1);
  auto z = torch::rand({n}) * 4 + 2;
  auto x = (torch::rand({n}) * 2 - 1) * z * std::tan(fov_x / 2);
  auto y = (torch::rand({n}) * 2 - 1) * z * std::tan(fov_y / 2);
  auto xyz = torch::stack({x, y, z}, 1);
  auto g = gaussians_from_points(xyz, torch::rand({n, channels}), degree);
  torch::NoGradGuard ng;
  g.sh.narrow(1, 1, g.sh.size(1) - 1).normal_(0, 0.05);
  g.quats.normal_();
  g.opacity_logits.normal_(0, 1);
  return g;
}

struct Row {
  double total = 0;
  StepTimings t;
  double densify_call = 0;
};

Row run_case(int w, int h, int channels, int64_t n, int degree, int iters, bool sparse = false) {
  const int views = 8;
  std::vector<TrainView> train;
  for (int i = 0; i < views; ++i) {
    auto cam = camera(w, h, 0.02 * (i - views / 2));
    train.push_back({"v" + std::to_string(i), cam, torch::rand({channels, h, w})});
  }
  TrainerOptions o;
  o.iterations = 1000000;
  o.sh_degree = degree;
  o.schedule.from = 1000000;  // no densification inside the timed steps
  o.schedule.until = 1000000;
  o.schedule.sh_degree_every = 1;  // the full degree from the first step
  o.psnr_every = 0;
  o.sparse_adam = sparse;
  const double fov_x = 2 * std::atan(w / (2 * 0.8 * w)), fov_y = 2 * std::atan(h / (2 * 0.8 * w));
  Trainer trainer(train, field(n, channels, degree, fov_x, fov_y), 4.0, o);
  for (int i = 0; i < 3; ++i) trainer.step();  // warm-up
  Row row;
  for (int i = 0; i < iters; ++i) {
    auto t0 = std::chrono::steady_clock::now();
    auto r = trainer.step();
    row.total += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    row.t.render += r.timings.render;
    row.t.loss += r.timings.loss;
    row.t.backward += r.timings.backward;
    row.t.optimizer += r.timings.optimizer;
    row.t.densify += r.timings.densify;
  }
  for (double* v : {&row.total, &row.t.render, &row.t.loss, &row.t.backward, &row.t.optimizer, &row.t.densify})
    *v /= iters;
  // One densification of the current field with statistics from a step (half of them "hot").
  {
    Gaussians g = trainer.gaussians().clone();
    g.make_leaves();
    GaussianAdam adam(g, LearningRates{}, 4.0, 100);
    Densifier d(g.size());
    auto grad = torch::rand({g.size(), 2}) * 4e-4;
    d.accumulate(grad, torch::full({g.size()}, 3, torch::kInt32));
    DensifyOptions dopt;
    dopt.max_gaussians = g.size() + g.size() / 10;
    auto t0 = std::chrono::steady_clock::now();
    d.densify_and_prune(g, adam, 4.0, true, 1, dopt);
    row.densify_call = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  return row;
}

void print(const std::string& name, int w, int h, int c, int64_t n, int degree, int threads, const Row& r) {
  std::printf("%-5s %4dx%-4d C=%-2d N=%-7lld SH=%d thr=%d w=%d | %8.2f ms/iter | render %7.2f  loss %6.2f"
              "  backward %7.2f  adam %6.2f  dens-stats %5.2f | densify call %7.1f ms | VmHWM %ld MB\n",
              name.c_str(), w, h, c, static_cast<long long>(n), degree, threads, raster_vector_width(), r.total,
              r.t.render, r.t.loss, r.t.backward, r.t.optimizer, r.t.densify, r.densify_call, vm_hwm_kb() / 1024);
  std::fflush(stdout);
}

}  // namespace

// Adam's update loop alone, scalar and vectorised alternately in this process, over case (a)'s state at
// SH degree 1 (50k rows of 3 + 3 + 4 + 1 + 4·32 floats), one thread: the ratio holds while the machine's
// speed drifts.
void adam_loops(int reps) {
  const int64_t n = 50000LL * (3 + 3 + 4 + 1 + 4 * 32);
  torch::manual_seed(2);
  auto p = torch::randn({n}), g = torch::randn({n}) * 1e-3, m = torch::zeros({n}), v = torch::zeros({n});
  std::vector<double> times[2];
  for (int r = 0; r < reps; ++r)
    for (int vec = 0; vec < 2; ++vec) {
      const AdamScalars s = adam_scalars(2.5e-3, 0.9, 0.999, 1e-15, r + 1);
      const auto t0 = Clock::now();
      adam_update(p.data_ptr<float>(), g.data_ptr<float>(), m.data_ptr<float>(), v.data_ptr<float>(), n, s, vec);
      times[vec].push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
  for (auto& t : times) std::sort(t.begin(), t.end());
  const double scalar = times[0][times[0].size() / 2], vectorised = times[1][times[1].size() / 2];
  std::printf("adam update, %lld floats, 1 thread, median of %d: scalar %.2f ms, vectorised %.2f ms, ratio %.2fx\n",
              static_cast<long long>(n), reps, scalar, vectorised, scalar / vectorised);
}

int main(int argc, char** argv) {
  lrf::keep_freed_memory();  // as the lrf binary does, so that the figures match its runs
  std::string which = "all";
  int iters = 20;
  bool quick = false;
  int only_degree = -1;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--case") && i + 1 < argc) which = argv[++i];
    else if (!std::strcmp(argv[i], "--iters") && i + 1 < argc) iters = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--quick")) quick = true;
    else if (!std::strcmp(argv[i], "--sh") && i + 1 < argc) only_degree = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--width") && i + 1 < argc) {
      if (!set_raster_vector_width(std::atoi(argv[++i]))) {
        std::fprintf(stderr, "vector width %s is not available on this CPU\n", argv[i]);
        return 2;
      }
    }
    else {
      std::fprintf(stderr, "usage: bench_train [--quick] [--case a|b|all] [--sh 0|1|3] [--iters N] [--width 1|4|8]\n");
      return 2;
    }
  }
  if (which == "a" || which == "all") adam_loops(quick ? 3 : 9);
  for (int threads : {1, 2}) {
    if (quick && threads == 1) continue;
    lrf::set_thread_count(threads);
    if (which == "a" || which == "all")
      for (int degree : {0, 1, 3}) {
        if (only_degree >= 0 && degree != only_degree) continue;
        print("(a)", 63, 47, 32, 50000, degree, threads, run_case(63, 47, 32, 50000, degree, iters));
        print("(a)sp", 63, 47, 32, 50000, degree, threads, run_case(63, 47, 32, 50000, degree, iters, true));
      }
    if (which == "b" || which == "all")
      for (int64_t n : {100000LL, 300000LL}) {
        if (quick && n > 100000) continue;
        print("(b)", 504, 378, 3, n, 3, threads, run_case(504, 378, 3, n, 3, std::max(3, iters / 4)));
      }
  }
  return 0;
}
