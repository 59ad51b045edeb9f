#pragma once
// Stable Diffusion's KL-f8 AutoencoderKL (the ldm "first stage"; SD 1.x / 2.x / SDXL VAEs): ResNet
// blocks (GroupNorm 32, eps 1e-6, SiLU), channel multipliers per level, a stride-2 conv after every
// level but the last (input padded right/bottom by one), mid block with one single-head self-attention,
// quant_conv / post_quant_conv 1x1, nearest x2 upsampling + 3x3 conv in the decoder. Images in [-1,1]
// inside; the encoder outputs a diagonal Gaussian (mean, log-variance) and encode() returns its mean.
// Native key names are ldm's ("encoder.down.0.block.0.norm1.weight"); diffusers names
// ("encoder.down_blocks.0.resnets.0.norm1.weight", to_q / query ...) are mapped (kl_vae_keys.h).
// Sizes (ch, ch_mult, res blocks, latent channels) are read from the weights.
#include <vector>

#include "lrf/autoencoder/autoencoder.h"

namespace lrf {

struct KLConfig {
  int ch = 128;
  std::vector<int> ch_mult = {1, 2, 4, 4};
  int num_res_blocks = 2;
  int z_channels = 4;
  // Inferred from ldm-layout keys; throws lrf::Error naming `what` when the keys are not a KL-VAE.
  static KLConfig from_weights(const StateDict& ldm_keys, const std::string& what);
};

class KLAutoencoder : public Autoencoder {
 public:
  // Randomly initialised (PyTorch default init).
  explicit KLAutoencoder(const KLConfig& config);
  // From one state dict holding both halves (ldm or diffusers layout, optionally under
  // "first_stage_model." or "vae."), loaded strictly.
  KLAutoencoder(const StateDict& weights, const std::string& name);

  std::string kind() const override { return "kl-f8"; }
  int latent_channels() const override { return config_.z_channels; }
  at::Tensor encode(const at::Tensor& images) override;
  at::Tensor encode_sample(const at::Tensor& images) override;
  // Group norms throughout the decoder make every pixel depend on the whole latent: no local split.
  at::Tensor decode_unclamped(const at::Tensor& latents) override;
  // Posterior moments [B, 2C, h, w]: mean then log-variance (clamped to [-30, 20] as ldm does).
  at::Tensor encode_moments(const at::Tensor& images);
  const KLConfig& config() const { return config_; }
  // "decoder.up.I....": 2^(levels - 1 - I), its upsampling 2^(levels - I); the output layers the
  // highest; post_quant_conv, conv_in and mid 1.
  int decoder_parameter_scale(const std::string& name) const override;

 protected:
  torch::nn::Module& encoder_module() override;
  torch::nn::Module& decoder_module() override;
  StateDict encoder_keys(const StateDict& file) const override;
  StateDict decoder_keys(const StateDict& file) const override;

 private:
  void build();
  KLConfig config_;
  std::shared_ptr<torch::nn::Module> encoder_;  // children: encoder, quant_conv
  std::shared_ptr<torch::nn::Module> decoder_;  // children: post_quant_conv, decoder
};

}  // namespace lrf
