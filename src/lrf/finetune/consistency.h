#pragma once
// How 3D-consistent an encoder's latents are on a scene (Stage I's evidence): the mean L1 between the
// latents of corresponding pixels over the scene's view pairs, that error relative to the latents' own
// spread (so that an encoder cannot look consistent by shrinking its outputs), the autoencoder's round-trip
// PSNR on the views, and the share of latent spectral energy above half the Nyquist frequency.
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/finetune/pair_batches.h"

namespace lrf {

struct ConsistencyReport {
  size_t views = 0, pairs = 0, matches = 0;
  int width = 0, height = 0;
  double correspondence_l1 = 0;           // mean over matches and channels, raw latent units
  double latent_mean_abs_deviation = 0;   // mean |z - mean_c(z)| over views, pixels and channels
  double correspondence_relative = 0;     // correspondence_l1 / latent_mean_abs_deviation
  double roundtrip_psnr = 0;              // mean over views, dB
  double high_frequency_share = 0;        // mean over views
  nlohmann::json to_json() const;
};

// Encodes every view of `scene` once (full image) and measures over all of its correspondence pairs.
ConsistencyReport measure_consistency(const PairScene& scene, Autoencoder& ae);

}  // namespace lrf
