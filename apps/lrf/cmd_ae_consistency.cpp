// lrf ae consistency: how 3D-consistent an encoder's latents are on a posed scene (Stage I's evidence).
#include <cstdio>
#include <memory>

#include "autoencoder_option.h"
#include "command.h"
#include "lrf/core/log.h"
#include "lrf/finetune/consistency.h"
#include "scene_options.h"

namespace {

struct ConsistencyOptions {
  std::string scene, autoencoder = "taef2", encoder, decoder, correspondences;
  lrf::SceneOptions scene_options;
  int min_matches = 15;
  bool json = false;
};

int run_consistency(const ConsistencyOptions& o) {
  lrf::PairScene ps = lrf::load_pair_scene(o.scene, o.scene_options, 0, o.correspondences, o.min_matches);
  auto ae = lrf::load_autoencoder(o.autoencoder, o.encoder, o.decoder);
  lrf::log_info("autoencoder: " + ae->description());
  lrf::ConsistencyReport r = lrf::measure_consistency(ps, *ae);
  if (o.json) {
    nlohmann::json j = r.to_json();
    j["scene"] = o.scene;
    j["autoencoder"] = ae->description();
    j["correspondence_source"] = ps.correspondences.source;
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("%s: %zu views at %dx%d, %zu pairs, %zu matches (%s)\n"
                "correspondence L1      %.5f (latent units; relative to the latents' spread: %.4f)\n"
                "round-trip PSNR        %.3f dB\n"
                "high-frequency energy  %.4f of the latent spectrum above half Nyquist\n",
                o.scene.c_str(), r.views, r.width, r.height, r.pairs, r.matches, ps.correspondences.source.c_str(),
                r.correspondence_l1, r.correspondence_relative, r.roundtrip_psnr, r.high_frequency_share);
  }
  return 0;
}

lrf::cli::CommandRegistration reg(41, [](CLI::App& root) {
  CLI::App* ae = root.get_subcommand("ae");
  auto* cmd = ae->add_subcommand(
      "consistency",
      "Measure an encoder's multi-view consistency on a posed scene: mean L1 between latents at corresponding pixels "
      "(bilinear at pixel/8) over every view pair, the same relative to the latents' mean absolute deviation, the "
      "round-trip PSNR, and the share of latent spectral energy above half the Nyquist frequency. Every view is used; "
      "images are centre-cropped to multiples of 8");
  auto o = std::make_shared<ConsistencyOptions>();
  cmd->add_option("scene", o->scene, "Scene folder (COLMAP, LLFF or NeRF, with poses)")->required();
  lrf::cli::add_autoencoder_option(cmd, &o->autoencoder, "whose latents are compared");
  cmd->add_option("--encoder", o->encoder, "Replace the encoder's weights (e.g. from `lrf finetune-encoder`)");
  cmd->add_option("--decoder", o->decoder, "Replace the decoder's weights (for the round trip)");
  cmd->add_option("--correspondences", o->correspondences,
                  "Correspondence file from `lrf corr SCENE --crop8` at the same resolution (default: COLMAP tracks, "
                  "else SCENE/database.db, else lrf's SIFT matcher)");
  cmd->add_option("--min-matches", o->min_matches, "Ignore view pairs with fewer correspondences")->capture_default_str();
  cmd->add_flag("--json", o->json, "Print one JSON object");
  lrf::cli::add_scene_options(cmd, &o->scene_options);
  lrf::cli::on_run(cmd, [o] { return run_consistency(*o); });
});

}  // namespace
