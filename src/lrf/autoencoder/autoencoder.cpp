#include "lrf/autoencoder/autoencoder.h"

#include <torch/torch.h>

#include "lrf/autoencoder/strict_load.h"
#include "lrf/core/error.h"
#include "lrf/core/safetensors.h"

namespace lrf {
namespace {

std::vector<at::Tensor> params(torch::nn::Module& m) { return m.parameters(true); }

void set_trainable(torch::nn::Module& m, bool on) {
  for (auto& p : m.parameters(true)) p.requires_grad_(on);
}

}  // namespace

std::vector<at::Tensor> Autoencoder::encoder_parameters() { return params(encoder_module()); }
std::vector<at::Tensor> Autoencoder::decoder_parameters(int max_scale) {
  if (max_scale <= 0) return params(decoder_module());
  std::vector<at::Tensor> out;
  for (const auto& p : decoder_module().named_parameters(true))
    if (decoder_parameter_scale(p.key()) <= max_scale) out.push_back(p.value());
  return out;
}

void Autoencoder::set_encoder_trainable(bool trainable) { set_trainable(encoder_module(), trainable); }

void Autoencoder::set_decoder_trainable(bool trainable, int max_scale) {
  for (auto& p : decoder_module().named_parameters(true))
    p.value().requires_grad_(trainable && (max_scale <= 0 || decoder_parameter_scale(p.key()) <= max_scale));
}

int Autoencoder::decoder_parameter_scale(const std::string&) const { return 1; }

void Autoencoder::load_encoder(const std::string& path) {
  load_strict(encoder_module(), encoder_keys(load_state_dict(path)), path + " (" + kind() + " encoder)");
}

void Autoencoder::load_decoder(const std::string& path) {
  load_strict(decoder_module(), decoder_keys(load_state_dict(path)), path + " (" + kind() + " decoder)");
}

StateDict Autoencoder::encoder_state() { return module_state(encoder_module()); }
StateDict Autoencoder::decoder_state() { return module_state(decoder_module()); }

void Autoencoder::save_encoder(const std::string& path) {
  write_safetensors(path, encoder_state(), {{"lrf_autoencoder", kind()}, {"lrf_half", "encoder"}});
}

void Autoencoder::save_decoder(const std::string& path) {
  write_safetensors(path, decoder_state(), {{"lrf_autoencoder", kind()}, {"lrf_half", "decoder"}});
}

void Autoencoder::set_channels_last(bool on) {
  channels_last_ = on;
  torch::NoGradGuard no_grad;
  auto format = on ? at::MemoryFormat::ChannelsLast : at::MemoryFormat::Contiguous;
  for (auto* m : {&encoder_module(), &decoder_module()}) {
    for (auto& p : m->parameters(true)) {
      if (p.dim() == 4) p.set_data(p.contiguous(format));
    }
  }
}

at::Tensor Autoencoder::decode(const at::Tensor& latents) { return decode_unclamped(latents).clamp(0, 1); }

at::Tensor Autoencoder::decode_global(const at::Tensor& latents) {
  check_latents(latents);
  return latents;
}

at::Tensor Autoencoder::decode_local(const at::Tensor& features) { return decode_unclamped(features); }

at::Tensor Autoencoder::decode_local_window(const at::Tensor& features, const CellRect& inner, const WindowEdges&) {
  if (features.dim() != 4 || inner.h < 1 || inner.w < 1 || inner.y < 0 || inner.x < 0 ||
      inner.y + inner.h > features.size(2) || inner.x + inner.w > features.size(3)) {
    fail("decode_local_window: the wanted rectangle does not lie inside the window " +
         std::string(c10::str(features.sizes())));
  }
  return decode_local(features).narrow(2, 8 * inner.y, 8 * inner.h).narrow(3, 8 * inner.x, 8 * inner.w);
}

void Autoencoder::set_precision(Precision p) { precision_ = resolve_precision(p); }

at::Tensor Autoencoder::to_network(const at::Tensor& t) const {
  // One pass for both conversions. The cast is differentiable: a float32 input gets a float32 gradient.
  const auto dtype = precision_ == Precision::bf16 ? at::kBFloat16 : at::kFloat;
  return t.to(dtype, /*non_blocking=*/false, /*copy=*/false,
              channels_last_ ? at::MemoryFormat::ChannelsLast : at::MemoryFormat::Contiguous);
}

at::Tensor Autoencoder::from_network(const at::Tensor& t) {
  return t.to(at::kFloat, /*non_blocking=*/false, /*copy=*/false, at::MemoryFormat::Contiguous);
}

void Autoencoder::check_images(const at::Tensor& images) const {
  if (images.dim() != 4 || images.size(1) != 3) {
    fail("autoencoder: images must be [B,3,H,W], got " + std::string(c10::str(images.sizes())));
  }
  if (images.size(2) < 8 || images.size(3) < 8 || images.size(2) % 8 || images.size(3) % 8) {
    fail("autoencoder: image height and width must be positive multiples of 8, got " +
         std::to_string(images.size(2)) + "x" + std::to_string(images.size(3)) +
         " (crop or pad the image first; the CLI centre-crops)");
  }
}

void Autoencoder::check_latents(const at::Tensor& latents) const {
  if (latents.dim() != 4 || latents.size(1) != latent_channels()) {
    fail("autoencoder: latents must be [B," + std::to_string(latent_channels()) + ",h,w], got " +
         std::string(c10::str(latents.sizes())));
  }
}

}  // namespace lrf
