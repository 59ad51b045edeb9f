// lrf serve: a local web viewer for a trained field (RGB, latent, feature or latent NeRF): the browser moves
// the camera, the server renders (and decodes) the frames.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <thread>

#include "command.h"
#include "detail_options.h"
#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/detail/detail_frames.h"
#include "lrf/field_kinds/field_type.h"
#include "lrf/frames/field_frames.h"
#include "lrf/viewer/viewer_server.h"
#include "scene_override_option.h"

namespace {

struct ServeCliOptions {
  std::string run, decoder;
  lrf::viewer::ServeOptions server;
  bool detail = false;
  lrf::detail::DetailOptions detail_options;
};

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

int run_serve(const ServeCliOptions& o) {
  using namespace lrf;
  std::unique_ptr<FieldFrames> frames = open_field_frames(o.run, o.decoder);
  if (o.detail) frames = std::make_unique<lrf::detail::DetailFrames>(std::move(frames), o.detail_options);
  log_info(frames->describe());
  if (!viewer::is_loopback_host(o.server.host))
    log_warn("serving on " + o.server.host + ": anyone who can reach this address can look at the field "
             "(the default, 127.0.0.1, keeps it to this machine)");
  viewer::ViewerServer server(std::move(frames), o.server);
  const int port = server.start();
  const std::string host = o.server.host.find(':') != std::string::npos ? "[" + o.server.host + "]" : o.server.host;
  // The address on stdout (flushed), so that scripts and tests can read which port was chosen.
  std::printf("lrf serve: http://%s:%d/ (Ctrl-C stops)\n", host.c_str(), port);
  std::fflush(stdout);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  server.stop();
  const auto s = server.stats();
  log_info("stopped: " + std::to_string(s.frames) + " frames rendered, " + std::to_string(s.stale) + " stale requests dropped, " +
           std::to_string(s.rejected) + " bad requests refused");
  return 0;
}

lrf::cli::CommandRegistration reg(24, [](CLI::App& root) {
  auto* cmd = root.add_subcommand("serve", "A local web viewer for a trained field: orbit, pan, zoom and fly in the "
                                           "browser while lrf renders (and decodes) the frames");
  auto o = std::make_shared<ServeCliOptions>();
  cmd->add_option("run", o->run, "Output folder of lrf train or lrf refine, or a method's folder of lrf compare "
                  "(an RGB or latent field, a feature field, a latent NeRF)")->required();
  cmd->add_option("--port", o->server.port, "TCP port (0: any free port; the address is printed)")->capture_default_str();
  cmd->add_option("--host", o->server.host, "Address to listen on; the default keeps the viewer to this machine. "
                  "Another address exposes the field to the network")->capture_default_str();
  cmd->add_option("--decoder", o->decoder, "Latent fields and latent NeRFs: decode with these decoder weights (e.g. Stage III's; default: the "
                  "decoder a refined field was fitted through, else the autoencoder's)");
  cmd->add_flag("--detail", o->detail,
                "Show frames with the detail pass (the nearest training photographs carried into each frame with the "
                "field's depth and blended in where they agree; splat fields)");
  lrf::cli::add_detail_options(cmd, &o->detail_options);
  cmd->add_option("--max-side", o->server.max_side, "Largest frame width or height a page may ask for")->capture_default_str();
  cmd->add_option("--jpeg-quality", o->server.jpeg_quality, "JPEG quality of the frames (1..100)")
      ->capture_default_str()->check(CLI::Range(1, 100));
  lrf::cli::add_scene_override_option(cmd);
  lrf::cli::on_run(cmd, [o] { return run_serve(*o); });
});

}  // namespace
