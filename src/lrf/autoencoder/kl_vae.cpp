#include "lrf/autoencoder/kl_vae.h"

#include <cmath>
#include <regex>
#include <set>

#include <torch/torch.h>

#include "lrf/autoencoder/kl_vae_keys.h"
#include "lrf/autoencoder/mixed_layers.h"
#include "lrf/autoencoder/strict_load.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

namespace nn = torch::nn;
namespace F = torch::nn::functional;

MixedGroupNorm norm(int channels) { return MixedGroupNorm(nn::GroupNormOptions(32, channels).eps(1e-6)); }
MixedConv2d conv(int in, int out, int k, int stride = 1, int pad = -1) {
  return MixedConv2d(nn::Conv2dOptions(in, out, k).stride(stride).padding(pad < 0 ? k / 2 : pad));
}

struct ResnetBlockImpl : nn::Module {
  ResnetBlockImpl(int in, int out) {
    norm1 = register_module("norm1", norm(in));
    conv1 = register_module("conv1", conv(in, out, 3));
    norm2 = register_module("norm2", norm(out));
    conv2 = register_module("conv2", conv(out, out, 3));
    if (in != out) nin_shortcut = register_module("nin_shortcut", conv(in, out, 1));
  }
  at::Tensor forward(const at::Tensor& x) {
    at::Tensor h = conv1(torch::silu(norm1(x)));
    h = conv2(torch::silu(norm2(h)));
    return (nin_shortcut ? nin_shortcut(x) : x) + h;
  }
  MixedGroupNorm norm1{nullptr}, norm2{nullptr};
  MixedConv2d conv1{nullptr}, conv2{nullptr}, nin_shortcut{nullptr};
};
TORCH_MODULE(ResnetBlock);

// Single-head self-attention over all h*w positions.
struct AttnBlockImpl : nn::Module {
  explicit AttnBlockImpl(int c) {
    norm_ = register_module("norm", norm(c));
    q = register_module("q", conv(c, c, 1));
    k = register_module("k", conv(c, c, 1));
    v = register_module("v", conv(c, c, 1));
    proj_out = register_module("proj_out", conv(c, c, 1));
  }
  at::Tensor forward(const at::Tensor& x) {
    at::Tensor h = norm_(x);
    const auto b = x.size(0), c = x.size(1), hw = x.size(2) * x.size(3);
    at::Tensor qs = q(h).reshape({b, c, hw}).transpose(1, 2);  // [b, hw, c]
    at::Tensor ks = k(h).reshape({b, c, hw});                   // [b, c, hw]
    at::Tensor vs = v(h).reshape({b, c, hw});                   // [b, c, hw]
    // The softmax in float32 (its sum over every position loses too much in bf16), the weights back in
    // the compute dtype for the second product.
    at::Tensor w = torch::softmax(torch::bmm(qs, ks) / std::sqrt(static_cast<double>(c)), 2, at::kFloat)
                       .to(x.scalar_type());  // [b, hw(q), hw(k)]
    at::Tensor out = torch::bmm(vs, w.transpose(1, 2)).reshape(x.sizes());
    return x + proj_out(out);
  }
  MixedGroupNorm norm_{nullptr};
  MixedConv2d q{nullptr}, k{nullptr}, v{nullptr}, proj_out{nullptr};
};
TORCH_MODULE(AttnBlock);

// Stride-2 3x3 conv on the input padded by one column right and one row bottom (ldm's asymmetric pad).
struct DownsampleImpl : nn::Module {
  explicit DownsampleImpl(int c) { conv_ = register_module("conv", conv(c, c, 3, 2, 0)); }
  at::Tensor forward(const at::Tensor& x) { return conv_(F::pad(x, F::PadFuncOptions({0, 1, 0, 1}))); }
  MixedConv2d conv_{nullptr};
};
TORCH_MODULE(Downsample);

struct UpsampleImpl : nn::Module {
  explicit UpsampleImpl(int c) { conv_ = register_module("conv", conv(c, c, 3)); }
  at::Tensor forward(const at::Tensor& x) {
    return conv_(F::interpolate(x, F::InterpolateFuncOptions().scale_factor(std::vector<double>{2.0, 2.0}).mode(torch::kNearest)));
  }
  MixedConv2d conv_{nullptr};
};
TORCH_MODULE(Upsample);

struct MidImpl : nn::Module {
  explicit MidImpl(int c) {
    block_1 = register_module("block_1", ResnetBlock(c, c));
    attn_1 = register_module("attn_1", AttnBlock(c));
    block_2 = register_module("block_2", ResnetBlock(c, c));
  }
  at::Tensor forward(const at::Tensor& x) { return block_2(attn_1(block_1(x))); }
  ResnetBlock block_1{nullptr}, block_2{nullptr};
  AttnBlock attn_1{nullptr};
};
TORCH_MODULE(Mid);

// One resolution level: "block" (ResnetBlocks) and optionally "downsample" / "upsample".
struct LevelImpl : nn::Module {
  nn::ModuleList block;
  Downsample down{nullptr};
  Upsample up{nullptr};
  LevelImpl() { block = register_module("block", nn::ModuleList()); }
  at::Tensor forward(at::Tensor x) {
    for (auto& b : *block) x = b->as<ResnetBlockImpl>()->forward(x);
    if (down) x = down(x);
    if (up) x = up(x);
    return x;
  }
};
TORCH_MODULE(Level);

struct EncoderImpl : nn::Module {
  explicit EncoderImpl(const KLConfig& cfg) {
    conv_in = register_module("conv_in", conv(3, cfg.ch, 3));
    down = register_module("down", nn::ModuleList());
    int in = cfg.ch;
    const int levels = static_cast<int>(cfg.ch_mult.size());
    for (int i = 0; i < levels; ++i) {
      Level level;
      const int out = cfg.ch * cfg.ch_mult[i];
      for (int j = 0; j < cfg.num_res_blocks; ++j) level->block->push_back(ResnetBlock(j == 0 ? in : out, out));
      if (i != levels - 1) level->down = level->register_module("downsample", Downsample(out));
      down->push_back(level);
      in = out;
    }
    mid = register_module("mid", Mid(in));
    norm_out = register_module("norm_out", norm(in));
    conv_out = register_module("conv_out", conv(in, 2 * cfg.z_channels, 3));
  }
  at::Tensor forward(at::Tensor x) {
    x = conv_in(x);
    for (auto& l : *down) x = l->as<LevelImpl>()->forward(x);
    return conv_out(torch::silu(norm_out(mid(x))));
  }
  MixedConv2d conv_in{nullptr}, conv_out{nullptr};
  nn::ModuleList down{nullptr};
  Mid mid{nullptr};
  MixedGroupNorm norm_out{nullptr};
};
TORCH_MODULE(Encoder);

struct DecoderImpl : nn::Module {
  explicit DecoderImpl(const KLConfig& cfg) {
    const int levels = static_cast<int>(cfg.ch_mult.size());
    int in = cfg.ch * cfg.ch_mult.back();
    conv_in = register_module("conv_in", conv(cfg.z_channels, in, 3));
    mid = register_module("mid", Mid(in));
    // ldm stores levels bottom-up (up.0 is the full-resolution level) but runs them top-down.
    std::vector<Level> built(levels);
    for (int i = levels - 1; i >= 0; --i) {
      Level level;
      const int out = cfg.ch * cfg.ch_mult[i];
      for (int j = 0; j <= cfg.num_res_blocks; ++j) level->block->push_back(ResnetBlock(j == 0 ? in : out, out));
      if (i != 0) level->up = level->register_module("upsample", Upsample(out));
      built[i] = level;
      in = out;
    }
    up = register_module("up", nn::ModuleList());
    for (auto& l : built) up->push_back(l);
    norm_out = register_module("norm_out", norm(in));
    conv_out = register_module("conv_out", conv(in, 3, 3));
  }
  at::Tensor forward(at::Tensor z) {
    at::Tensor x = mid(conv_in(z));
    for (int i = static_cast<int>(up->size()) - 1; i >= 0; --i) x = (*up)[i]->as<LevelImpl>()->forward(x);
    return conv_out(torch::silu(norm_out(x)));
  }
  MixedConv2d conv_in{nullptr}, conv_out{nullptr};
  nn::ModuleList up{nullptr};
  Mid mid{nullptr};
  MixedGroupNorm norm_out{nullptr};
};
TORCH_MODULE(Decoder);

struct EncoderHalf : nn::Module {
  explicit EncoderHalf(const KLConfig& cfg) {
    encoder = register_module("encoder", Encoder(cfg));
    quant_conv = register_module("quant_conv", conv(2 * cfg.z_channels, 2 * cfg.z_channels, 1));
  }
  Encoder encoder{nullptr};
  MixedConv2d quant_conv{nullptr};
};

struct DecoderHalf : nn::Module {
  explicit DecoderHalf(const KLConfig& cfg) {
    post_quant_conv = register_module("post_quant_conv", conv(cfg.z_channels, cfg.z_channels, 1));
    decoder = register_module("decoder", Decoder(cfg));
  }
  MixedConv2d post_quant_conv{nullptr};
  Decoder decoder{nullptr};
};

bool is_encoder_key(const std::string& k) { return k.rfind("encoder.", 0) == 0 || k.rfind("quant_conv.", 0) == 0; }
bool is_decoder_key(const std::string& k) {
  return k.rfind("decoder.", 0) == 0 || k.rfind("post_quant_conv.", 0) == 0;
}

// Keeps native keys of one half; `other` decides what belongs to the other half (dropped).
StateDict half(const StateDict& ldm, bool (*other)(const std::string&)) {
  StateDict out;
  for (const auto& item : ldm)
    if (!other(item.key())) out.insert(item.key(), item.value());
  return out;
}

// Keeps only the keys `mine` accepts.
StateDict only(const StateDict& sd, bool (*mine)(const std::string&)) {
  StateDict out;
  for (const auto& item : sd)
    if (mine(item.key())) out.insert(item.key(), item.value());
  return out;
}

}  // namespace

KLConfig KLConfig::from_weights(const StateDict& w, const std::string& what) {
  KLConfig cfg;
  const at::Tensor* conv_in = w.find("encoder.conv_in.weight");
  const at::Tensor* dec_in = w.find("decoder.conv_in.weight");
  if (!conv_in && !dec_in) fail(what, "not a KL-f8 VAE: no encoder.conv_in / decoder.conv_in weights");
  static const std::regex level_re(R"(^(encoder\.down|decoder\.up)\.(\d+)\.block\.(\d+)\.conv1\.weight$)");
  std::map<int, int> level_out;  // level -> output channels (from its first block's conv1)
  int max_block = -1;
  bool from_encoder = conv_in != nullptr;
  std::smatch m;
  for (const auto& item : w) {
    if (!std::regex_match(item.key(), m, level_re)) continue;
    bool enc = m[1].str() == "encoder.down";
    if (enc != from_encoder) continue;
    int level = std::stoi(m[2]), block = std::stoi(m[3]);
    if (level > 16) fail(what, "implausible KL-VAE level count");
    max_block = std::max(max_block, block);
    if (block == 0) level_out[level] = static_cast<int>(item.value().size(0));
  }
  if (level_out.empty()) fail(what, "not a KL-f8 VAE: no resnet blocks found");
  cfg.ch = static_cast<int>(from_encoder ? conv_in->size(0) : level_out[0]);
  cfg.num_res_blocks = from_encoder ? max_block + 1 : max_block;  // the decoder has one more per level
  cfg.ch_mult.clear();
  for (const auto& [level, out] : level_out) {
    if (level != static_cast<int>(cfg.ch_mult.size()) || out % cfg.ch) fail(what, "inconsistent KL-VAE levels");
    cfg.ch_mult.push_back(out / cfg.ch);
  }
  if (cfg.ch_mult.size() != 4) {
    fail(what, "a KL-f8 VAE has 4 levels (3 downsamplings), these weights have " + std::to_string(cfg.ch_mult.size()));
  }
  if (const auto* pq = w.find("post_quant_conv.weight")) {
    cfg.z_channels = static_cast<int>(pq->size(0));
  } else if (const auto* q = w.find("quant_conv.weight")) {
    cfg.z_channels = static_cast<int>(q->size(0) / 2);
  }
  return cfg;
}

KLAutoencoder::KLAutoencoder(const KLConfig& config) : config_(config) { build(); }

KLAutoencoder::KLAutoencoder(const StateDict& weights, const std::string& name) {
  StateDict ldm = kl_keys_to_ldm(weights);
  config_ = KLConfig::from_weights(ldm, name);
  build();
  StateDict enc = half(ldm, is_decoder_key), dec = half(ldm, is_encoder_key);
  // Keys of neither half are reported once, with the encoder's.
  std::string e = strict_mismatch(*encoder_, enc), d = strict_mismatch(*decoder_, only(dec, is_decoder_key));
  if (!e.empty() || !d.empty()) {
    fail(name, "weights do not fit the kl-f8 architecture: " + (e.empty() ? "" : "encoder: " + e + " ") +
                   (d.empty() ? "" : "decoder: " + d));
  }
  load_strict(*encoder_, enc, name + " (kl-f8 encoder)");
  load_strict(*decoder_, dec, name + " (kl-f8 decoder)");
}

void KLAutoencoder::build() {
  encoder_ = std::make_shared<EncoderHalf>(config_);
  decoder_ = std::make_shared<DecoderHalf>(config_);
}

torch::nn::Module& KLAutoencoder::encoder_module() { return *encoder_; }
torch::nn::Module& KLAutoencoder::decoder_module() { return *decoder_; }

int KLAutoencoder::decoder_parameter_scale(const std::string& name) const {
  const int levels = static_cast<int>(config_.ch_mult.size());
  static const std::regex up(R"(^decoder\.up\.(\d+)\.(block|upsample)\..*$)");
  std::smatch m;
  if (std::regex_match(name, m, up)) {
    const int level = std::stoi(m[1].str());
    return 1 << (levels - 1 - level + (m[2].str() == "upsample" ? 1 : 0));
  }
  if (name.rfind("decoder.norm_out.", 0) == 0 || name.rfind("decoder.conv_out.", 0) == 0) return 1 << (levels - 1);
  return 1;
}

StateDict KLAutoencoder::encoder_keys(const StateDict& file) const {
  return half(kl_keys_to_ldm(file, static_cast<int>(config_.ch_mult.size())), is_decoder_key);
}
StateDict KLAutoencoder::decoder_keys(const StateDict& file) const {
  return half(kl_keys_to_ldm(file, static_cast<int>(config_.ch_mult.size())), is_encoder_key);
}

at::Tensor KLAutoencoder::encode_moments(const at::Tensor& images) {
  check_images(images);
  auto& e = static_cast<EncoderHalf&>(*encoder_);
  at::Tensor moments = from_network(e.quant_conv(e.encoder(to_network(images * 2 - 1))));
  auto parts = moments.chunk(2, 1);
  return torch::cat({parts[0], parts[1].clamp(-30.0, 20.0)}, 1);
}

at::Tensor KLAutoencoder::encode(const at::Tensor& images) {
  return encode_moments(images).narrow(1, 0, config_.z_channels);
}

at::Tensor KLAutoencoder::encode_sample(const at::Tensor& images) {
  auto parts = encode_moments(images).chunk(2, 1);
  return parts[0] + torch::exp(0.5 * parts[1]) * torch::randn_like(parts[0]);
}

at::Tensor KLAutoencoder::decode_unclamped(const at::Tensor& latents) {
  check_latents(latents);
  auto& d = static_cast<DecoderHalf&>(*decoder_);
  at::Tensor x = from_network(d.decoder(d.post_quant_conv(to_network(latents))));
  return (x + 1) * 0.5;
}

}  // namespace lrf
