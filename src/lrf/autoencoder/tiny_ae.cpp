#include "lrf/autoencoder/tiny_ae.h"

#include <cmath>
#include <regex>

#include <torch/torch.h>

#include "lrf/autoencoder/conv/onednn_conv.h"
#include "lrf/autoencoder/mixed_layers.h"
#include "lrf/autoencoder/strict_load.h"
#include "lrf/autoencoder/tiny_block.h"
#include "lrf/autoencoder/tiny_fused.h"
#include "lrf/core/cpu_features.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

namespace nn = torch::nn;

nn::Upsample upsample2() {
  return nn::Upsample(nn::UpsampleOptions().scale_factor(std::vector<double>{2.0, 2.0}).mode(torch::kNearest));
}

// Runs layers [from, to) of a Sequential.
at::Tensor run_layers(nn::SequentialImpl& s, size_t from, size_t to, at::Tensor x) {
  auto it = s.begin() + static_cast<std::ptrdiff_t>(from);
  for (size_t i = from; i < to; ++i, ++it) x = it->forward(x);
  return x;
}

const std::regex kIndexKey(R"(^(\d+)\.(.*)$)");

// Indices of blocks that carry the pool branch, from keys like "11.pool.0.weight".
std::set<int> pool_blocks(const StateDict& sd) {
  std::set<int> out;
  std::smatch m;
  for (const auto& item : sd) {
    if (std::regex_match(item.key(), m, kIndexKey) && m[2].str().rfind("pool.", 0) == 0) out.insert(std::stoi(m[1]));
  }
  return out;
}

// Renames "<prefix>N.rest" to "(N+shift).rest", drops keys of the other half, keeps anything else
// unchanged so that strict loading reports it.
StateDict canonical(const StateDict& file, const std::string& own, const std::string& other, int shift) {
  StateDict out;
  std::smatch m;
  for (const auto& item : file) {
    const std::string& k = item.key();
    if (k.rfind(other, 0) == 0) continue;
    std::string name = k;
    if (k.rfind(own, 0) == 0) {
      std::string rest = k.substr(own.size());
      if (std::regex_match(rest, m, kIndexKey)) name = std::to_string(std::stoi(m[1]) + shift) + "." + m[2].str();
    }
    if (out.contains(name)) fail("tiny autoencoder: key " + name + " appears twice");
    out.insert(name, item.value());
  }
  return out;
}

}  // namespace

TinyAutoencoder::TinyAutoencoder(int latent_channels, bool pool) {
  std::set<int> enc, dec;
  if (pool) enc = {11, 12, 13}, dec = {3, 4, 5};
  build(latent_channels, enc, dec);
}

TinyAutoencoder::TinyAutoencoder(const StateDict& encoder, const std::string& encoder_name,
                                 const StateDict& decoder, const std::string& decoder_name) {
  StateDict enc = encoder_keys(encoder), dec = decoder_keys(decoder);
  // Latent channels: the last encoder conv's outputs, else the first decoder conv's inputs.
  int channels = 4;
  if (const auto* w = enc.find("14.weight"); w && w->dim() == 4) {
    channels = static_cast<int>(w->size(0));
  } else if (const auto* d = dec.find("1.weight"); d && d->dim() == 4) {
    channels = static_cast<int>(d->size(1));
  }
  build(channels, pool_blocks(enc), pool_blocks(dec));
  std::string e = strict_mismatch(*encoder_, enc), d = strict_mismatch(*decoder_, dec);
  if (!e.empty() || !d.empty()) {
    fail(encoder_name == decoder_name ? encoder_name : encoder_name + " + " + decoder_name,
         "weights do not fit the tiny autoencoder architecture: " + (e.empty() ? "" : "encoder: " + e + " ") +
             (d.empty() ? "" : "decoder: " + d));
  }
  load_strict(*encoder_, enc, encoder_name + " (tiny encoder)");
  load_strict(*decoder_, dec, decoder_name + " (tiny decoder)");
}

TinyAutoencoder::~TinyAutoencoder() = default;

void TinyAutoencoder::build(int c, const std::set<int>& ep, const std::set<int>& dp) {
  latent_channels_ = c;
  fused_ = std::make_unique<TinyFusedLayers>();
  fused_on_ = fused_conv_enabled();
  auto block = [](const std::set<int>& pools, int index) { return TinyBlock(64, pools.count(index) > 0); };
  encoder_ = nn::Sequential();
  encoder_->push_back(tiny_conv3x3(3, 64));                                   // 0
  encoder_->push_back(block(ep, 1));                                          // 1
  for (int level = 0; level < 3; ++level) {                                   // 2..13
    encoder_->push_back(tiny_conv3x3(64, 64, 2, false));
    for (int i = 0; i < 3; ++i) encoder_->push_back(block(ep, 3 + 4 * level + i));
  }
  encoder_->push_back(tiny_conv3x3(64, c));                                   // 14

  decoder_ = nn::Sequential();
  decoder_->push_back(nn::Functional([](const at::Tensor& x) { return torch::tanh(x / 3) * 3; })); // 0
  decoder_->push_back(tiny_conv3x3(c, 64));                                   // 1
  decoder_->push_back(nn::ReLU(nn::ReLUOptions().inplace(true)));             // 2
  for (int level = 0; level < 3; ++level) {                                   // 3..17
    for (int i = 0; i < 3; ++i) decoder_->push_back(block(dp, 3 + 5 * level + i));
    decoder_->push_back(upsample2());
    decoder_->push_back(tiny_conv3x3(64, 64, 1, false));
  }
  decoder_->push_back(block(dp, 18));                                         // 18
  decoder_->push_back(tiny_conv3x3(64, 3));                                   // 19

  // The local part starts after the last block with a pool branch; its reach in latent cells is the sum,
  // over its 3x3 convolutions, of one pixel at that convolution's resolution (1/2, 1/4 or 1/8 of a cell
  // after one, two or three upsamplings). TAEF2: 8.125 cells -> 9.
  decoder_split_ = dp.empty() ? 0 : static_cast<size_t>(*dp.rbegin()) + 1;
  double reach = 0, scale = 1;
  for (size_t i = decoder_split_; i < decoder_->size(); ++i) {
    const auto& m = decoder_->ptr(i);
    if (m->as<nn::Upsample>()) scale *= 2;
    if (m->as<MixedConv2d>()) reach += 1 / scale;
    if (const auto* b = m->as<TinyBlock>()) {
      if (b->pool) fail("tiny autoencoder: a group-norm block after the decoder's split");
      reach += 3 / scale;
    }
  }
  local_reach_ = static_cast<int>(std::ceil(reach - 1e-9));
}

at::Tensor TinyAutoencoder::encode(const at::Tensor& images) {
  check_images(images);
  return from_network(run(*encoder_, 0, encoder_->size(), to_network(images)));
}

at::Tensor TinyAutoencoder::decode_unclamped(const at::Tensor& latents) {
  check_latents(latents);
  return from_network(run(*decoder_, 0, decoder_->size(), to_network(latents)));
}

at::Tensor TinyAutoencoder::decode_global(const at::Tensor& latents) {
  check_latents(latents);
  // Handed back in float32 like every output; decode_local's cast back to bf16 is exact, so the split
  // still decodes exactly as decode_unclamped does.
  return from_network(run(*decoder_, 0, decoder_split_, to_network(latents)));
}

at::Tensor TinyAutoencoder::decode_local(const at::Tensor& features) {
  if (features.dim() != 4 || features.size(1) != (decoder_split_ == 0 ? latent_channels_ : 64)) {
    fail("tiny autoencoder: decode_local takes decode_global's features, got " + std::string(c10::str(features.sizes())));
  }
  return from_network(run(*decoder_, decoder_split_, decoder_->size(), to_network(features)));
}

int TinyAutoencoder::decoder_parameter_scale(const std::string& name) const {
  std::smatch m;
  if (!std::regex_match(name, m, kIndexKey)) fail("tiny autoencoder: no decoder layer holds parameter " + name);
  const size_t layer = std::stoul(m[1].str());
  int scale = 1;
  for (size_t i = 0; i < layer && i < decoder_->size(); ++i)
    if (decoder_->ptr(i)->as<nn::Upsample>()) scale *= 2;
  return scale;
}

bool TinyAutoencoder::uses_fused_layers() const {
  return fused_on_ && channels_last() && !at::GradMode::is_enabled();
}

at::Tensor TinyAutoencoder::run(nn::SequentialImpl& half, size_t from, size_t to, const at::Tensor& x) {
  if (uses_fused_layers()) return fused_->run(half, from, to, x);
  return run_layers(half, from, to, x);
}

StateDict TinyAutoencoder::encoder_keys(const StateDict& file) const {
  return canonical(file, "encoder.layers.", "decoder.", 0);
}

StateDict TinyAutoencoder::decoder_keys(const StateDict& file) const {
  return canonical(file, "decoder.layers.", "encoder.", 1);
}

}  // namespace lrf
