// lrf: latent radiance fields on the command line. Each job is a subcommand (see cmd_*.cpp).
#include <algorithm>
#include <cstdio>
#include <exception>
#include <vector>

#include <c10/util/Exception.h>

#include "command.h"
#include "lrf/core/allocator.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/precision.h"
#include "lrf/core/run_info.h"
#include "lrf/core/threads.h"

namespace lrf::cli {
namespace {

struct Registered {
  int order;
  SetupFunction setup;
};

std::vector<Registered>& registrations() {
  static std::vector<Registered> list;
  return list;
}

std::vector<std::pair<CLI::App*, RunFunction>>& runners() {
  static std::vector<std::pair<CLI::App*, RunFunction>> list;
  return list;
}

}  // namespace

CommandRegistration::CommandRegistration(int order, SetupFunction setup) {
  registrations().push_back({order, std::move(setup)});
}

void on_run(CLI::App* command, RunFunction run) { runners().emplace_back(command, std::move(run)); }

}  // namespace lrf::cli

int main(int argc, char** argv) {
  using namespace lrf;
  keep_freed_memory();
  set_command_line(argc, argv);
  CLI::App app{"lrf: latent radiance fields. 3D reconstruction and novel-view synthesis in the latent "
               "space of an image autoencoder (encoder alignment, latent Gaussian splatting, decoder "
               "alignment, and their evaluation)."};
  app.set_version_flag("--version", version_string());
  int threads = 0;
  bool quiet = false;
  bool log_json = false;
  app.add_option("--threads", threads, "Worker threads for every computation (0 = all cores)")
      ->capture_default_str();
  std::string precision;
  app.add_option("--precision", precision,
                 "Arithmetic of the autoencoders: fp32, bf16, or auto (bf16 where the CPU has native bf16: "
                 "AVX512_BF16 or AMX; fp32 elsewhere). Default: $LRF_PRECISION if set, else auto. In bf16 on "
                 "AVX512_BF16, the 3x3 convolutions run as Winograd's: F(3x3, 3x3) in inference and in Stage I / III "
                 "training's forward and input gradient ($LRF_WINOGRAD_TILE=2: F(2x2, 3x3)), F(2x2, 3x3) in "
                 "their weight gradient ($LRF_WINOGRAD=0: oneDNN's direct convolution instead); in inference the "
                 "decoder's last one, to 3 outputs, runs in a kernel of its own ($LRF_FUSED_CONV=0: oneDNN's)");
  app.add_flag("--quiet,-q", quiet, "Print only warnings and errors");
  app.add_flag("--log-json", log_json, "Print progress and log messages as JSON lines on stderr");
  app.require_subcommand(1);
  auto* help = app.add_subcommand("help", "Show this help, or a subcommand's: lrf help [COMMAND]");
  std::vector<std::string> help_topic;
  help->add_option("command", help_topic, "Subcommand to describe");

  auto& regs = cli::registrations();
  std::stable_sort(regs.begin(), regs.end(), [](auto& a, auto& b) { return a.order < b.order; });
  for (auto& r : regs) r.setup(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (help->parsed()) {
    CLI::App* target = &app;
    for (const auto& name : help_topic) {
      try {
        target = target->get_subcommand(name);
      } catch (const CLI::OptionNotFound&) {
        std::fprintf(stderr, "error: no subcommand '%s'\n", name.c_str());
        return 2;
      }
    }
    std::printf("%s", target->help().c_str());
    return 0;
  }

  set_log_mode(log_json ? LogMode::json : quiet ? LogMode::quiet : LogMode::normal);
  set_thread_count(threads);
  try {
    if (!precision.empty()) set_default_precision(parse_precision(precision));
    resolve_precision(default_precision());  // a bad $LRF_PRECISION or $LRF_CPU_BF16 is reported before any work
  } catch (const lrf::Error& e) {
    log_error(e.what());
    return 2;
  }
  for (auto& [command, run] : cli::runners()) {
    if (!command->parsed()) continue;
    bool leaf = true;
    for (auto* sub : command->get_subcommands()) leaf = leaf && !sub->parsed();
    if (!leaf) continue;
    try {
      return run();
    } catch (const lrf::Error& e) {
      log_error(e.what());
      return 1;
    } catch (const c10::Error& e) {
      log_error(std::string("libtorch: ") + e.what_without_backtrace());
      return 1;
    } catch (const std::exception& e) {
      log_error(e.what());
      return 1;
    }
  }
  std::fprintf(stderr, "%s", app.help().c_str());
  return 2;
}
