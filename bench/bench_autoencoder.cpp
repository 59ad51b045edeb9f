// Encode / decode time and peak memory of the autoencoders on CPU: TAEF2 (real weights from
// ../shared/models when present, else random weights of the same architecture) and the full-size
// KL-f8 VAE (ch 128, random weights) at 504x376 and 512x512, default and channels-last layouts.
//
// Reported per benchmark: wall time per call, process CPU seconds per call (all threads; on a loaded
// shared machine CPU / threads approximates the uncontended wall time), and peak resident memory
// (VmHWM, reset before each benchmark through /proc/self/clear_refs).
//   ./build/bench_autoencoder [--threads N] [google-benchmark flags, e.g. --benchmark_filter=taef2]
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>

#include <benchmark/benchmark.h>
#include <torch/torch.h>

#include "lrf/core/allocator.h"
#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/kl_vae.h"
#include "lrf/autoencoder/tiny_ae.h"
#include "lrf/core/error.h"
#include "lrf/core/threads.h"

namespace {

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Peak resident set size in MB (VmHWM).
double peak_rss_mb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
  }
  return 0;
}

void reset_peak_rss() { std::ofstream("/proc/self/clear_refs") << "5"; }

std::unique_ptr<lrf::Autoencoder> make_taef2() {
  try {
    return lrf::load_autoencoder("taef2");
  } catch (const lrf::Error& e) {
    std::fprintf(stderr, "bench: %s; using random TAEF2-shaped weights\n", e.what());
    return std::make_unique<lrf::TinyAutoencoder>(32, true);
  }
}

std::unique_ptr<lrf::Autoencoder> make_kl() { return std::make_unique<lrf::KLAutoencoder>(lrf::KLConfig{}); }

// Models are built once and shared by the benchmarks of a family.
lrf::Autoencoder& model(const std::string& family) {
  static std::unique_ptr<lrf::Autoencoder> taef2, kl;
  if (family == "taef2") {
    if (!taef2) taef2 = make_taef2();
    return *taef2;
  }
  if (!kl) kl = make_kl();
  return *kl;
}

void run(benchmark::State& state, const std::string& family, bool decode) {
  torch::NoGradGuard no_grad;
  const int width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  const bool channels_last = state.range(2) != 0;
  lrf::Autoencoder& ae = model(family);
  ae.set_channels_last(channels_last);
  torch::manual_seed(0);
  at::Tensor x = torch::rand({1, 3, height, width});
  at::Tensor z = ae.encode(x);
  reset_peak_rss();
  ae.decode(z);  // warm-up (oneDNN primitive creation)
  double cpu = 0;
  for (auto _ : state) {
    double c0 = process_cpu_seconds();
    at::Tensor out = decode ? ae.decode(z) : ae.encode(x);
    benchmark::DoNotOptimize(out.data_ptr());
    cpu += process_cpu_seconds() - c0;
  }
  state.counters["cpu_s_per_call"] = cpu / static_cast<double>(state.iterations());
  state.counters["peak_rss_MB"] = peak_rss_mb();
  state.counters["threads"] = lrf::thread_count();
  state.SetLabel(std::string(channels_last ? "channels-last" : "contiguous"));
}

void taef2_encode(benchmark::State& s) { run(s, "taef2", false); }
void taef2_decode(benchmark::State& s) { run(s, "taef2", true); }
void kl_encode(benchmark::State& s) { run(s, "kl", false); }
void kl_decode(benchmark::State& s) { run(s, "kl", true); }

void sizes(benchmark::internal::Benchmark* b) {
  for (int cl : {0, 1}) {
    b->Args({504, 376, cl});
    b->Args({512, 512, cl});
  }
  b->ArgNames({"w", "h", "channels_last"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

BENCHMARK(taef2_encode)->Apply(sizes)->Iterations(3);
BENCHMARK(taef2_decode)->Apply(sizes)->Iterations(3);
BENCHMARK(kl_encode)->Apply(sizes)->Iterations(1);
BENCHMARK(kl_decode)->Apply(sizes)->Iterations(1);

}  // namespace

int main(int argc, char** argv) {
  lrf::keep_freed_memory();  // as the lrf binary does, so that the figures match its runs
  int threads = 2;
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], "--threads") == 0) {
      threads = std::atoi(argv[i + 1]);
      for (int j = i; j + 2 < argc + 1; ++j) argv[j] = argv[j + 2];
      argc -= 2;
      break;
    }
  }
  lrf::set_thread_count(threads);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) > 0) std::fprintf(stderr, "load average at start: %.2f (on %d threads)\n", load[0], threads);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
