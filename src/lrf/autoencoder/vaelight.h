#pragma once
// VAElight (github.com/Graphnull/VAElight): a small 4-channel, factor-8 encoder and decoder distilled from
// Stable Diffusion's KL-f8 VAE, so its latent space is SD's. The paper's regime: the autoencoder loses
// about as much as a field does (round trip on LLFF about 23 dB, like SD's VAE), where TAEF2's 32 channels
// lose little.
//  - Encoder: images in [-1, 1]; the sum of a strided branch (2x2 stride-2 convs between 3x3 convs) and a
//    branch that average-pools the image by 8 then runs five 3x3 convs. LeakyReLU(0.01) between layers.
//  - Decoder: four branches that each end in an RGB image at 1, 2, 4 and 8 times the latent resolution
//    (3x3 convs, 2x2 stride-2 transposed convs); the three coarser ones are upsampled bilinearly to the full
//    resolution and all four added; the sum is in [-1, 1].
// The latent scaling, in this one place: latents are SD's raw ones, exactly what the encoder outputs (per
// channel std about 4-5.5 on photos, means far from 0). SD's diffusion scale factor 0.18215 is not applied
// anywhere in lrf: fields normalise each channel by its range over the training views, whatever its scale.
// Native key names are the checkpoints' own ("cv1.weight", "c4v3.bias", ...; the encoder and decoder reuse
// the names cv1..cv6, so each half is read from its own file, or from one file with "encoder." /
// "decoder." prefixes). The encoder checkpoint's LayerNorm weights norm1..norm3, which its forward pass
// never uses, are recognised and dropped.
#include <memory>

#include "lrf/autoencoder/autoencoder.h"

namespace lrf {

class VaeLightAutoencoder : public Autoencoder {
 public:
  // Randomly initialised (PyTorch's default initialisation).
  VaeLightAutoencoder();
  // From the two halves' state dicts (any key layout encoder_keys / decoder_keys read), loaded strictly;
  // the names are used in errors.
  VaeLightAutoencoder(const StateDict& encoder, const std::string& encoder_name, const StateDict& decoder,
                      const std::string& decoder_name);
  ~VaeLightAutoencoder() override;

  std::string kind() const override { return "vaelight"; }
  int latent_channels() const override { return 4; }
  at::Tensor encode(const at::Tensor& images) override;
  at::Tensor decode_unclamped(const at::Tensor& latents) override;
  // Every layer is local (no norms): decode_global is the identity and a pixel depends on the latent
  // cells within decode_local_reach() of its own (the coarsest branch's four 3x3 convolutions, then the
  // bilinear upsampling's neighbour).
  int decode_local_reach() const override { return 5; }
  // The resolution of the layer's output, in multiples of the latent's: 1 for the coarse branch and the
  // first convolutions of the others, 2, 4 or 8 after each transposed convolution.
  int decoder_parameter_scale(const std::string& name) const override;

  // Whether a file's keys are VAElight's (either half, prefixed or not).
  static bool recognises(const StateDict& weights);

 protected:
  torch::nn::Module& encoder_module() override;
  torch::nn::Module& decoder_module() override;
  StateDict encoder_keys(const StateDict& file) const override;
  StateDict decoder_keys(const StateDict& file) const override;

 private:
  std::shared_ptr<torch::nn::Module> encoder_;
  std::shared_ptr<torch::nn::Module> decoder_;
};

}  // namespace lrf
