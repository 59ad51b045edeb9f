// lrf: latent radiance fields on the command line. Each job is a subcommand (see cmd_*.cpp).
#include <algorithm>
#include <cstdio>
#include <exception>
#include <vector>

#include <c10/util/Exception.h>

#include "command.h"
#include "exit_status.h"
#include "unknown_command.h"
#include "lrf/core/allocator.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/core/openmp_wait.h"
#include "lrf/core/precision.h"
#include "lrf/core/run_info.h"
#include "lrf/core/stop_request.h"
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

namespace {

// A command line CLI11 cannot parse: its message (or, for a mistyped subcommand, which one and the closest
// name), as a JSON line with --log-json; exit status 2. --help and --version end here too, with 0.
int parse_error_exit(CLI::App& app, const CLI::ParseError& e, int argc, char** argv) {
  if (e.get_exit_code() == 0) return app.exit(e);
  std::string message = e.what();
  const std::string unknown = unknown_command(app, argc, argv);
  if (!unknown.empty()) {
    const std::string near = closest_command(app, unknown);
    message = "unknown command '" + unknown + "'" + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
              "; `lrf --help` lists the commands";
  }
  if (log_mode() == LogMode::json || !unknown.empty()) {
    log_error(message);
  } else {
    app.exit(e);  // CLI11's own wording, with its pointer to --help
  }
  return kExitUsage;
}

}  // namespace

}  // namespace lrf::cli

namespace {

// The commands whose work takes long enough that starting the program a second time (to set OpenMP's
// wait policy, openmp_wait.h) costs nothing next to it; --help, scene info and the like are not started again.
bool runs_long(const CLI::App& app) {
  static const char* const kLong[] = {"train", "refine", "compare", "pipeline", "finetune-encoder",
                                      "finetune-decoder", "eval", "render", "serve", "demo"};
  for (const CLI::App* sub : app.get_subcommands())
    for (const char* name : kLong)
      if (sub->get_name() == name) return true;
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace lrf;
  keep_freed_memory();
  apply_isa_cap_to_onednn();  // before oneDNN's first primitive reads its own cap
  set_command_line(argc, argv);
  CLI::App app{"lrf: latent radiance fields. 3D reconstruction and novel-view synthesis in the latent "
               "space of an image autoencoder (encoder alignment, latent Gaussian splatting, decoder "
               "alignment, and their evaluation)."};
  app.set_version_flag("--version", version_string());
  app.footer(cli::kExitStatusHelp);
  int threads = 0;
  bool quiet = false;
  bool log_json = false;
  // A negative count used to be taken silently as "all cores"; more than 1024 is a typo, not a machine.
  app.add_option("--threads", threads, "Worker threads for every computation (0 = all cores)")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  std::string precision;
  app.add_option("--precision", precision,
                 "Arithmetic of the autoencoders: fp32, bf16, or auto (bf16 where the CPU has native bf16: "
                 "AVX512_BF16 or AMX; fp32 elsewhere). Default: $LRF_PRECISION if set, else auto. In bf16 on "
                 "AVX512_BF16, the 3x3 convolutions run as Winograd's: F(3x3, 3x3) in inference and in Stage I / III "
                 "training's forward and input gradient ($LRF_WINOGRAD_TILE=2: F(2x2, 3x3)), F(2x2, 3x3) in "
                 "their weight gradient ($LRF_WINOGRAD=0: oneDNN's direct convolution instead); in inference the "
                 "decoder's last one, to 3 outputs, runs in a kernel of its own ($LRF_FUSED_CONV=0: oneDNN's). In fp32 on "
                 "AVX2 or AVX-512F, the 3x3 convolutions run as Winograd's F(4x4, 3x3) in inference and in all three "
                 "training passes ($LRF_WINOGRAD_F32_TILE=2 or 6: F(2x2, 3x3) or F(6x6, 3x3)). "
                 "$LRF_CPU_ISA=avx512|avx2|baseline caps the vector instructions lrf and oneDNN use");
  app.add_flag("--quiet,-q", quiet, "Print only warnings and errors");
  app.add_flag("--log-json", log_json, "Print progress and log messages as JSON lines on stderr");
  app.require_subcommand(1);
  auto* help = app.add_subcommand("help", "Show this help, or a subcommand's: lrf help [COMMAND]");
  std::vector<std::string> help_topic;
  help->add_option("command", help_topic, "Subcommand to describe");

  auto& regs = cli::registrations();
  std::stable_sort(regs.begin(), regs.end(), [](auto& a, auto& b) { return a.order < b.order; });
  for (auto& r : regs) r.setup(app);

  // --log-json is looked for before parsing, so that an error in the command line itself is a JSON line too.
  for (int i = 1; i < argc && std::string(argv[i]) != "--"; ++i)
    if (std::string(argv[i]) == "--log-json") set_log_mode(LogMode::json);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli::parse_error_exit(app, e, argc, argv);
  }
  if (help->parsed()) {
    CLI::App* target = &app;
    for (const auto& name : help_topic) {
      try {
        target = target->get_subcommand(name);
      } catch (const CLI::OptionNotFound&) {
        log_error("no subcommand '" + name + "'");
        return cli::kExitUsage;
      }
    }
    std::printf("%s", target->help().c_str());
    return 0;
  }

  // A worker that spins while its partner thread waits for a core multiplied a busy machine's wall time.
  if (threads != 1 && runs_long(app)) restart_with_passive_openmp_wait(argv);
  set_log_mode(log_json ? LogMode::json : quiet ? LogMode::quiet : LogMode::normal);
  set_thread_count(threads);
  try {
    if (!precision.empty()) set_default_precision(parse_precision(precision));
    // Resolved here so that a bad $LRF_PRECISION or $LRF_CPU_BF16 is reported before any work.
    if (resolve_precision(default_precision()) == Precision::bf16 && !cpu_has_bf16()) {
      // Forced bf16 still runs, with bf16's rounding, but its convolutions are float32 ones on bf16 values:
      // a choice made for speed buys none here, which nothing else would tell the user.
      log_warn("bf16 on a CPU without native bf16 (AVX512_BF16 or AMX): the autoencoders' convolutions run in "
               "float32 on bf16-rounded values, no faster than fp32 and less exact; --precision auto picks fp32 here");
    }
  } catch (const lrf::Error& e) {
    log_error(e.what());
    return cli::kExitUsage;
  }
  for (auto& [command, run] : cli::runners()) {
    if (!command->parsed()) continue;
    bool leaf = true;
    for (auto* sub : command->get_subcommands()) leaf = leaf && !sub->parsed();
    if (!leaf) continue;
    try {
      return run();
    } catch (const lrf::Interrupted& e) {
      log_warn(e.what());
      return e.exit_status();
    } catch (const lrf::UsageError& e) {
      log_error(e.what());
      return cli::kExitUsage;
    } catch (const lrf::Error& e) {
      log_error(e.what());
      return cli::kExitFailed;
    } catch (const c10::Error& e) {
      log_error(std::string("libtorch: ") + e.what_without_backtrace());
      return cli::kExitFailed;
    } catch (const std::exception& e) {
      log_error(e.what());
      return cli::kExitFailed;
    }
  }
  std::fprintf(stderr, "%s", app.help().c_str());
  return cli::kExitUsage;
}
