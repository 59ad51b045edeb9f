#pragma once
// The tiny autoencoder family (TAESD, TAESDXL, TAESD3, TAEF1, TAEF2; github.com/madebyollin/taesd):
// 3x3 conv + ReLU residual blocks, three stride-2 convs down and three nearest-upsample + conv up, images
// in [0,1], raw latents. The decoder first soft-clamps latents with tanh(x/3)*3. TAEF2 (FLUX.2, 32
// channels) adds to the 1/8-resolution blocks a "pool" branch x += conv1x1(relu(GroupNorm(4)(conv1x1(x))))
// that mixes global statistics in. Latent channels and which blocks carry the branch are read from the
// weights. Native key names are those of the reference nn.Sequential: "0.weight", "1.conv.0.weight",
// "11.pool.1.weight", ...; the diffusers single-file layout ("encoder.layers.N", "decoder.layers.N") is
// also understood.
#include <memory>
#include <set>

#include <torch/nn/modules/container/sequential.h>

#include "lrf/autoencoder/autoencoder.h"

namespace lrf {

class TinyFusedLayers;

class TinyAutoencoder : public Autoencoder {
 public:
  // Builds the architecture the weights describe (encoder and decoder state dicts in any supported
  // key layout) and loads them strictly; `encoder_name` / `decoder_name` are used in errors.
  TinyAutoencoder(const StateDict& encoder, const std::string& encoder_name, const StateDict& decoder,
                  const std::string& decoder_name);
  // Randomly initialised network with the given latent channels; `pool` adds TAEF2's branch.
  TinyAutoencoder(int latent_channels, bool pool);
  ~TinyAutoencoder() override;

  std::string kind() const override { return "tiny"; }
  int latent_channels() const override { return latent_channels_; }
  at::Tensor encode(const at::Tensor& images) override;
  at::Tensor decode_unclamped(const at::Tensor& latents) override;
  // The split falls after the decoder's last block with a group-norm branch (none in TAESD: at the
  // start); the rest is 3x3 convolutions and nearest upsampling, whose reach is summed in latent cells.
  at::Tensor decode_global(const at::Tensor& latents) override;
  at::Tensor decode_local(const at::Tensor& features) override;
  int decode_local_reach() const override { return local_reach_; }
  // Each layer computed only where the layers after it need it: for a window with an inner rectangle of
  // n x n cells, the full-resolution layers work on n·8 pixels plus a few, not on the window's
  // (n + 2·reach)·8 (tiny_window_decode.cpp).
  at::Tensor decode_local_window(const at::Tensor& features, const CellRect& inner, const WindowEdges& edges) override;
  // 2 to the number of upsamplings before the parameter's layer ("12.weight": 4).
  int decoder_parameter_scale(const std::string& name) const override;
  // Whether inference may run the fused layers of tiny_fused.h (default: fused_conv_enabled()); off, it
  // runs the torch modules. For comparing the two.
  void set_fused_layers(bool on) { fused_on_ = on; }

 protected:
  torch::nn::Module& encoder_module() override { return *encoder_; }
  torch::nn::Module& decoder_module() override { return *decoder_; }
  StateDict encoder_keys(const StateDict& file) const override;
  StateDict decoder_keys(const StateDict& file) const override;

 private:
  // Inference (no gradient recorded) in channels-last layout runs the fused layers of tiny_fused.h.
  bool uses_fused_layers() const;
  // Layers [from, to) of a half, fused when uses_fused_layers(), else the modules.
  at::Tensor run(torch::nn::SequentialImpl& half, size_t from, size_t to, const at::Tensor& x);
  void build(int latent_channels, const std::set<int>& encoder_pool, const std::set<int>& decoder_pool);
  int latent_channels_ = 4;
  size_t decoder_split_ = 0;  // decoder layers [0, split) are global, [split, end) local
  int local_reach_ = 0;
  torch::nn::Sequential encoder_{nullptr};
  torch::nn::Sequential decoder_{nullptr};
  std::unique_ptr<TinyFusedLayers> fused_;
  bool fused_on_ = true;
};

}  // namespace lrf
