// Data-parallel Stage I on this machine: the same global batch and cores spent two ways, measured back to
// back in one run:
//   1 rank x 2 threads   one process, intra-op parallelism over the whole batch
//   2 ranks x 1 thread   two processes on localhost (c10d / Gloo), each on half the batch, gradients
//                        averaged by bucketed all-reduce overlapping the backward
// and the all-reduce alone: the encoder's gradient (float32) summed over the 2 ranks, the communication a
// step needs, which is what would remain (and grow with latency and bandwidth) across hosts. Also shown:
// the time the ranks waited on each other per step (the all-reduce left over after the backward, plus
// the loss terms' all-reduce).
//
// Stage I as `lrf finetune-encoder`: TAEF2 (../shared/models), llff-fern at --max-side 640, 192x192 crops,
// 2 pairs per step (global), checkpoints off.
//
// usage: bench_data_parallel [--steps N] [--scene DIR] [--pairs P] [--crop C]
//        (it starts its own ranks by running itself with --worker RANK PORT RESULT)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/core/atomic_file.h"
#include "lrf/core/log.h"
#include "lrf/core/run_info.h"
#include "lrf/core/threads.h"
#include "lrf/distributed/data_parallel_group.h"
#include "lrf/finetune/encoder_finetune.h"

extern char** environ;
namespace fs = std::filesystem;

namespace {

struct Settings {
  int steps = 12, pairs = 2, crop = 192;
  std::string scene;
};

std::string shared_dir() {
  const char* s = std::getenv("LRF_SHARED");
  return s && *s ? s : "../shared";
}

lrf::EncoderFinetuneOptions stage1(const Settings& s, const std::string& out) {
  lrf::EncoderFinetuneOptions o;
  o.scenes = {s.scene};
  o.autoencoder = "taef2";
  o.out = out;
  o.steps = s.steps;
  o.batch.pairs = s.pairs;
  o.batch.crop = s.crop;
  o.checkpoint_every = 0;
  o.force = true;
  return o;
}

// One rank of the 2-rank run: Stage I, then the all-reduce alone; rank 0 writes the numbers to `result`.
int worker(const Settings& s, int rank, int port, const std::string& result) {
  lrf::set_thread_count(1);
  lrf::set_log_mode(lrf::LogMode::quiet);
  lrf::EncoderFinetuneOptions o = stage1(s, fs::path(result).parent_path() / "two.safetensors");
  o.distributed = {rank, 2, rank, "127.0.0.1", port};
  const lrf::EncoderFinetuneResult r = lrf::finetune_encoder(o);

  // The all-reduce alone, on the encoder's gradient size, in a group of its own.
  int64_t elements = 0;
  for (const auto& p : lrf::load_autoencoder("taef2")->encoder_parameters()) elements += p.numel();
  lrf::DataParallelGroup group({rank, 2, rank, "127.0.0.1", port + 1}, "bench");
  at::Tensor gradient = at::ones({elements});
  for (int k = 0; k < 3; ++k) group.sum(gradient);
  group.barrier();
  const int reps = 20;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < reps; ++k) group.sum(gradient);
  const double allreduce = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
  if (rank == 0) {
    lrf::write_json_file(result, {{"seconds", r.seconds},
                                  {"steps", r.steps},
                                  {"sync_seconds", r.sync_seconds},
                                  {"allreduce_seconds", allreduce},
                                  {"gradient_elements", elements}});
  }
  return 0;
}

pid_t spawn_self(const std::vector<std::string>& args) {
  std::vector<std::string> all = {fs::read_symlink("/proc/self/exe").string()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) return -1;
  return pid;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  s.scene = shared_dir() + "/scenes/llff-fern";
  std::vector<std::string> forward;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (a == "--steps") {
      s.steps = std::atoi(next().c_str());
    } else if (a == "--pairs") {
      s.pairs = std::atoi(next().c_str());
    } else if (a == "--crop") {
      s.crop = std::atoi(next().c_str());
    } else if (a == "--scene") {
      s.scene = next();
    } else if (a == "--worker" && i + 3 < argc) {
      const int rank = std::atoi(argv[i + 1]), port = std::atoi(argv[i + 2]);
      return worker(s, rank, port, argv[i + 3]);
    } else {
      std::fprintf(stderr, "usage: bench_data_parallel [--steps N] [--scene DIR] [--pairs P] [--crop C]\n");
      return 2;
    }
  }
  const fs::path dir = fs::temp_directory_path() / ("lrf_bench_dp_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::vector<std::string> settings = {"--steps", std::to_string(s.steps), "--pairs", std::to_string(s.pairs),
                                       "--crop", std::to_string(s.crop), "--scene", s.scene};
  std::printf("Stage I: TAEF2, %s, %d pairs of %dx%d crops per step (global), %d steps per run\n", s.scene.c_str(),
              s.pairs, s.crop, s.crop, s.steps);

  // 1 rank x 2 threads, in this process.
  lrf::set_thread_count(2);
  lrf::set_log_mode(lrf::LogMode::quiet);
  const lrf::EncoderFinetuneResult one = lrf::finetune_encoder(stage1(s, (dir / "one.safetensors").string()));
  const double one_rate = one.steps / one.seconds;

  // 2 ranks x 1 thread, right after.
  const int port = 29700 + static_cast<int>(::getpid() % 200) * 2;
  const std::string result = (dir / "two.json").string();
  std::vector<pid_t> pids;
  for (int rank = 0; rank < 2; ++rank) {
    std::vector<std::string> args = settings;
    args.insert(args.end(), {"--worker", std::to_string(rank), std::to_string(port), result});
    pids.push_back(spawn_self(args));
  }
  bool ok = true;
  for (pid_t p : pids) {
    int status = 0;
    ::waitpid(p, &status, 0);
    ok = ok && WIFEXITED(status) && WEXITSTATUS(status) == 0;
  }
  if (!ok || !fs::exists(result)) {
    std::fprintf(stderr, "the 2-rank run failed\n");
    return 1;
  }
  const nlohmann::json two = lrf::read_json_file(result);
  const double two_rate = two["steps"].get<double>() / two["seconds"].get<double>();
  const double step_ms = 1000.0 / two_rate;
  const double sync_ms = 1000.0 * two["sync_seconds"].get<double>() / two["steps"].get<double>();
  const double allreduce_ms = 1000.0 * two["allreduce_seconds"].get<double>();
  std::printf("1 rank  x 2 threads: %.3f steps/s (%.0f ms/step)\n", one_rate, 1000.0 / one_rate);
  std::printf("2 ranks x 1 thread : %.3f steps/s (%.0f ms/step), %.2fx the 1-rank rate\n", two_rate, step_ms,
              two_rate / one_rate);
  std::printf("  waiting on the other rank: %.1f ms/step (%.1f%% of a step)\n", sync_ms, 100 * sync_ms / step_ms);
  std::printf("  all-reduce of the encoder gradient alone (%lld floats, %.1f MB): %.2f ms (%.2f%% of a step)\n",
              static_cast<long long>(two["gradient_elements"].get<int64_t>()),
              4e-6 * two["gradient_elements"].get<double>(), allreduce_ms, 100 * allreduce_ms / step_ms);
  fs::remove_all(dir);
  return 0;
}
