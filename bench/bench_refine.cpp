// Where a refinement step's time goes (lrf refine), per configuration, measured back to back: render (the
// latent, at latent resolution), decode forward + image loss, decode backward (down to the rendered latent:
// input gradients, and weight gradients where the decoder adapts), field backward (the rasterizer's),
// Adam on the Gaussians, the decoder's Adam, densification. Each configuration runs --steps steps of
// lrf refine on one latent field of llff-fern images_8 (fitted here in --field-iters steps, or --run DIR);
// the configurations alternate --reps times (A B C A B C ...); each part is the median over repetitions of
// its mean ms per step (the first logged row, 10 steps of warm-up, left out), with its share of the step,
// and the step's ratio to the first configuration's.
//
// Configurations (lrf refine's options; none densifies, as the default refinement does not: --densify-until's
// cost per call is in lrf refine's log):
//   whole       lrf refine's defaults: whole views, the decoder adapted at every layer
//   coarse      whole views, the decoder adapted at up to 2x the latent resolution (--decoder-scale 2)
//   frozen      whole views, frozen decoder (--decoder-lr 0)
//   crop256     256-pixel windows (--crop 256), the decoder adapted at every layer
//   crop128     128-pixel windows (--crop 128), the decoder adapted at every layer
//
// usage: bench_refine [--threads N] [--steps N] [--reps N] [--field-iters N] [--run DIR] [CONFIG ...]
//        (default: 2 threads, 30 steps, 3 repetitions, whole coarse frozen)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "lrf/core/allocator.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/threads.h"
#include "lrf/latent/latent_run.h"
#include "lrf/latent/latent_train_run.h"
#include "lrf/refine/refine.h"

namespace fs = std::filesystem;

namespace {

std::string shared_dir() {
  const char* s = std::getenv("LRF_SHARED");
  return s && *s ? s : "../shared";
}

// The parts as train_log.csv names them, in the order of a step.
const std::vector<std::pair<std::string, std::string>> kParts = {
    {"render_ms", "render"},           {"loss_ms", "decode forward + loss"}, {"loss_backward_ms", "decode backward"},
    {"backward_ms", "field backward"}, {"adam_ms", "Adam (Gaussians)"},      {"extra_adam_ms", "Adam (decoder)"},
    {"densify_ms", "densify"}};

lrf::RefineOptions configuration(const std::string& name) {
  lrf::RefineOptions o;
  if (name == "whole") return o;
  if (name == "coarse") {
    o.decoder_scale = 2;
  } else if (name == "frozen") {
    o.decoder_lr = 0;
  } else if (name == "crop256") {
    o.crop = 256;
  } else if (name == "crop128") {
    o.crop = 128;
  } else {
    lrf::fail("bench_refine: unknown configuration '" + name + "' (whole, coarse, frozen, crop256, crop128)");
  }
  return o;
}

// Mean per step of each column of a train_log.csv over its rows after the first.
std::map<std::string, double> mean_timings(const std::string& log) {
  std::ifstream in(log);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  std::istringstream header(line);
  for (std::string cell; std::getline(header, cell, ',');) names.push_back(cell);
  std::map<std::string, double> sum;
  int rows = 0;
  for (int row = 0; std::getline(in, line); ++row) {
    if (row == 0 || line.empty()) continue;  // warm-up
    std::istringstream cells(line);
    std::string cell;
    for (size_t k = 0; k < names.size() && std::getline(cells, cell, ','); ++k) sum[names[k]] += std::stod(cell);
    ++rows;
  }
  if (rows == 0) lrf::fail(log, "no rows after the warm-up: give more --steps");
  for (auto& [k, v] : sum) v /= rows;
  return sum;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_refine [--threads N] [--steps N] [--reps N] [--field-iters N] [--run DIR] [CONFIG ...]\n"
               "  CONFIG: whole coarse frozen crop256 crop128 (default: whole coarse frozen)\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  lrf::keep_freed_memory();  // as the lrf binary does
  int threads = 2, reps = 3;
  int64_t steps = 30, field_iters = 1000;
  std::string run;
  std::vector<std::string> configs;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) std::exit(usage());
      return argv[++i];
    };
    if (a == "--threads") threads = std::stoi(value());
    else if (a == "--steps") steps = std::stoll(value());
    else if (a == "--reps") reps = std::stoi(value());
    else if (a == "--field-iters") field_iters = std::stoll(value());
    else if (a == "--run") run = value();
    else if (a.rfind("--", 0) == 0) return usage();
    else configs.push_back(a);
  }
  if (configs.empty()) configs = {"whole", "coarse", "frozen"};
  if (steps < 20 || reps < 1 || threads < 1) return usage();
  try {
    lrf::set_thread_count(threads);
    lrf::set_log_mode(lrf::LogMode::quiet);
    for (const auto& c : configs) configuration(c);  // unknown names before any work
    const fs::path work = fs::temp_directory_path() / ("bench_refine_" + std::to_string(::getpid()));
    fs::create_directories(work);
    if (run.empty()) {
      lrf::LatentTrainOptions l;
      l.scene = shared_dir() + "/scenes/llff-fern";
      l.scene_options.images_dir = "images_8";
      l.iters = field_iters;
      l.out = (work / "field").string();
      l.force = true;
      std::printf("fitting a %lld-step latent field of llff-fern images_8 to refine...\n",
                  static_cast<long long>(field_iters));
      std::fflush(stdout);
      lrf::train_latent_field(l);
      run = l.out;
    }
    std::printf("refining %s: %lld steps per measurement, %d repetitions, %d threads\n", run.c_str(),
                static_cast<long long>(steps), reps, threads);
    std::map<std::string, std::map<std::string, std::vector<double>>> samples;  // config -> part -> per rep
    for (int r = 0; r < reps; ++r) {
      for (const auto& c : configs) {
        lrf::RefineOptions o = configuration(c);
        o.run = run;
        o.out = (work / ("refined_" + c)).string();
        o.steps = steps;
        o.force = true;
        o.checkpoint_every = 0;
        lrf::refine_latent_field(o);
        double total = 0;
        for (const auto& [column, value] : mean_timings(o.out + "/train_log.csv")) {
          samples[c][column].push_back(value);
          if (std::any_of(kParts.begin(), kParts.end(), [&](const auto& p) { return p.first == column; }))
            total += value;
        }
        samples[c]["total"].push_back(total);
        std::printf("  rep %d %-8s %7.1f ms per step\n", r + 1, c.c_str(), total);
        std::fflush(stdout);
      }
    }
    const double first = median(samples[configs[0]]["total"]);
    std::printf("\n%-22s", "ms per step (share)");
    for (const auto& c : configs) std::printf(" %18s", c.c_str());
    std::printf("\n");
    for (const auto& [column, label] : kParts) {
      std::printf("%-22s", label.c_str());
      for (const auto& c : configs) {
        const double ms = median(samples[c][column]), total = median(samples[c]["total"]);
        std::printf("   %7.1f (%4.1f %%)", ms, 100 * ms / total);
      }
      std::printf("\n");
    }
    std::printf("%-22s", "step");
    for (const auto& c : configs) std::printf("   %7.1f          ", median(samples[c]["total"]));
    std::printf("\n%-22s", "against the first");
    for (const auto& c : configs) std::printf("   %7.2fx         ", median(samples[c]["total"]) / first);
    std::printf("\n");
    fs::remove_all(work);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_refine: %s\n", e.what());
    return 1;
  }
  return 0;
}
