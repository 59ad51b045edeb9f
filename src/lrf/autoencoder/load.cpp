// The factory declared in autoencoder.h: resolve the files, pick the family from the weights' keys.
#include <torch/torch.h>

#include "lrf/autoencoder/autoencoder.h"
#include "lrf/autoencoder/kl_vae.h"
#include "lrf/autoencoder/resolve.h"
#include "lrf/autoencoder/tiny_ae.h"
#include "lrf/autoencoder/vaelight.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

// KL-VAEs have attention and resnet norms; the tiny family has neither.
bool is_kl(const StateDict& sd) {
  for (const auto& item : sd) {
    const auto& k = item.key();
    if (k.find("conv_in.") != std::string::npos || k.find("mid.attn_1") != std::string::npos ||
        k.find("mid_block") != std::string::npos) {
      return true;
    }
  }
  return false;
}

}  // namespace

std::unique_ptr<Autoencoder> load_autoencoder(const std::string& name_or_path, const std::string& encoder_override,
                                              const std::string& decoder_override) {
  AutoencoderFiles files = resolve_autoencoder(name_or_path);
  std::unique_ptr<Autoencoder> ae;
  StateDict enc = load_state_dict(files.encoder);
  if (is_kl(enc)) {
    if (files.decoder != files.encoder) {
      fail(files.source, "a KL-VAE is loaded from one weights file holding both halves");
    }
    ae = std::make_unique<KLAutoencoder>(enc, files.encoder);
  } else {
    StateDict dec = files.decoder == files.encoder ? enc : load_state_dict(files.decoder);
    if (VaeLightAutoencoder::recognises(enc) || VaeLightAutoencoder::recognises(dec)) {
      ae = std::make_unique<VaeLightAutoencoder>(enc, files.encoder, dec, files.decoder);
    } else {
      ae = std::make_unique<TinyAutoencoder>(enc, files.encoder, dec, files.decoder);
    }
  }
  std::string description = ae->kind() + " (" + std::to_string(ae->latent_channels()) + " ch) from " + files.source;
  if (!encoder_override.empty()) {
    ae->load_encoder(encoder_override);
    description += ", encoder " + encoder_override;
  }
  if (!decoder_override.empty()) {
    ae->load_decoder(decoder_override);
    description += ", decoder " + decoder_override;
  }
  ae->set_channels_last(true);
  ae->set_precision(default_precision());
  ae->set_description(description);
  return ae;
}

}  // namespace lrf
