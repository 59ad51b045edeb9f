#pragma once
// One interface for the image autoencoders whose latent space the radiance fields live in.
// Images are [B, 3, H, W] float32 in [0, 1] with H and W multiples of 8 (each model maps to its own
// input range inside); latents are "raw": exactly what the network's encoder outputs, no scaling.
// Every module stays trainable: Stage I fine-tunes encoder_parameters() with the decoder frozen, Stage
// III the reverse, and both call encode/decode under autograd.
// Whatever precision the networks compute in (set_precision), every tensor that goes in or comes out
// of these methods is float32, and so are the parameters and their gradients.
#include <memory>
#include <string>
#include <vector>

#include <torch/nn/module.h>

#include "lrf/core/precision.h"
#include "lrf/core/state_dict.h"

namespace lrf {

// A rectangle of latent cells: rows [y, y + h), columns [x, x + w).
struct CellRect {
  int64_t y = 0, x = 0, h = 0, w = 0;
};

// Which sides of a window of latent cells lie on the image's own edges.
struct WindowEdges {
  bool top = false, left = false, bottom = false, right = false;
};

class Autoencoder {
 public:
  virtual ~Autoencoder() = default;
  // "tiny" (TAESD family), "kl-f8" (Stable Diffusion's AutoencoderKL) or "vaelight" (distilled from it).
  virtual std::string kind() const = 0;
  virtual int latent_channels() const = 0;
  int factor() const { return 8; }

  // [B,3,H,W] in [0,1] -> [B,C,H/8,W/8]. The KL-VAE returns its posterior mean.
  virtual at::Tensor encode(const at::Tensor& images) = 0;
  // A sample of the posterior (the KL-VAE); deterministic encoders return encode().
  virtual at::Tensor encode_sample(const at::Tensor& images) { return encode(images); }
  // [B,C,h,w] -> [B,3,8h,8w] clamped to [0,1].
  at::Tensor decode(const at::Tensor& latents);
  // The same before the clamp: training through the decoder needs the gradient of saturated pixels too.
  virtual at::Tensor decode_unclamped(const at::Tensor& latents) = 0;

  // Decoding in two parts, so that a window of the image can be decoded exactly without decoding the
  // rest (training through the decoder on crops). decode_global maps latents [B,C,h,w] to features at
  // latent resolution that already hold every whole-image dependency of the decoder (TAEF2's group-norm
  // branches); decode_local maps a window of those features to that window's pixels, unclamped. Pixels
  // whose latent cell lies at least decode_local_reach() cells inside the window's edges (or on an edge
  // of the image itself) come out exactly as from decode_unclamped of the whole latent; a reach of -1
  // says the decoder has no such split (every pixel depends on the whole latent: decode it whole).
  virtual at::Tensor decode_global(const at::Tensor& latents);
  virtual at::Tensor decode_local(const at::Tensor& features);
  virtual int decode_local_reach() const { return -1; }
  // The pixels of one rectangle of decode_local's output, computing each layer only where the layers
  // after it need it: `features` is decode_global's output cut to a window of latent cells, `inner` the
  // rectangle of cells inside it whose pixels are wanted (relative to the window), `edges` which sides of
  // the window are the image's own edges (where the zero padding is the whole image's). Returns
  // [B, 3, 8·inner.h, 8·inner.w], exactly decode_local(features)'s pixels of `inner` when `inner` lies at
  // least decode_local_reach() cells inside every side that is not an image edge. This default decodes
  // the whole window and cuts `inner` out of it.
  virtual at::Tensor decode_local_window(const at::Tensor& features, const CellRect& inner, const WindowEdges& edges);

  std::vector<at::Tensor> encoder_parameters();
  // max_scale > 0: only the parameters of the decoder's layers that work at most max_scale times the
  // latent resolution (1 = at the latent's, 8 = every layer of a factor-8 decoder).
  std::vector<at::Tensor> decoder_parameters(int max_scale = 0);
  // Freezes or unfreezes one half (requires_grad), for fine-tuning the other. A decoder made trainable
  // with max_scale > 0 keeps its layers above that resolution frozen: training through them still carries
  // gradients to the latent, without their weight gradients (most of a whole view's backward).
  void set_encoder_trainable(bool trainable);
  void set_decoder_trainable(bool trainable, int max_scale = 0);
  // How many times the latent resolution the decoder layer holding parameter `name` (a native name, as
  // decoder_module() names it) works at. Default: 1 for every parameter.
  virtual int decoder_parameter_scale(const std::string& name) const;

  // Replace one half's weights (fine-tuned checkpoints): any format load_state_dict reads, any key
  // layout the model understands. Strict: missing, unexpected or mis-shaped keys are one error.
  void load_encoder(const std::string& path);
  void load_decoder(const std::string& path);
  // One half's weights, float32, in the model's native key layout, as safetensors (atomic write).
  void save_encoder(const std::string& path);
  void save_decoder(const std::string& path);
  StateDict encoder_state();
  StateDict decoder_state();

  // Runs the convolutions in channels-last layout (weights stored NHWC, inputs converted on entry):
  // oneDNN is markedly faster so on CPU (see bench_autoencoder). On by default for models built by
  // load_autoencoder. encode/decode always return contiguous (NCHW) tensors either way.
  void set_channels_last(bool on);
  bool channels_last() const { return channels_last_; }
  // The arithmetic of both halves: fp32, or bf16 (convolutions in bf16 with float32 accumulation, on
  // weights cast from their float32 parameters at each call; group norms, softmax and the outputs in
  // float32). Precision::automatic is resolved here against this CPU (resolve_precision). Models built
  // by load_autoencoder start at default_precision(), models constructed directly at fp32.
  void set_precision(Precision p);
  // fp32 or bf16 (never automatic).
  Precision precision() const { return precision_; }
  // Where the weights came from (for logs and run records).
  const std::string& description() const { return description_; }
  void set_description(std::string d) { description_ = std::move(d); }

 protected:
  // The two halves, whose parameter names are the native key names.
  virtual torch::nn::Module& encoder_module() = 0;
  virtual torch::nn::Module& decoder_module() = 0;
  // Maps a file's keys to native names of one half (other layouts renamed; keys of the other half
  // dropped). Anything else is kept so that strict loading reports it.
  virtual StateDict encoder_keys(const StateDict& file) const = 0;
  virtual StateDict decoder_keys(const StateDict& file) const = 0;
  // Throws lrf::Error unless images are [B,3,H,W] with H, W positive multiples of 8.
  void check_images(const at::Tensor& images) const;
  void check_latents(const at::Tensor& latents) const;
  // A float32 input in the dtype of set_precision and the layout of set_channels_last.
  at::Tensor to_network(const at::Tensor& t) const;
  // A network output back in float32 and contiguous (NCHW), in one pass.
  static at::Tensor from_network(const at::Tensor& t);

 private:
  std::string description_;
  bool channels_last_ = false;
  Precision precision_ = Precision::fp32;
};

// Loads an autoencoder by name ("taef2", "taesd", a folder name under a models directory) or by path
// (a folder holding *encoder* and *decoder* weight files, or one weights file holding both halves),
// chooses the architecture from the weights, and optionally replaces either half with a fine-tuned
// checkpoint. See resolve.h for the search order. The model runs channels-last at default_precision().
std::unique_ptr<Autoencoder> load_autoencoder(const std::string& name_or_path,
                                              const std::string& encoder_override = "",
                                              const std::string& decoder_override = "");

}  // namespace lrf
