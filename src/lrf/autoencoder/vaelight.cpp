#include "lrf/autoencoder/vaelight.h"

#include <cmath>
#include <map>
#include <vector>

#include <torch/torch.h>

#include "lrf/autoencoder/mixed_layers.h"
#include "lrf/autoencoder/strict_load.h"
#include "lrf/autoencoder/transposed_up2.h"
#include "lrf/core/error.h"

namespace lrf {
namespace {

namespace nn = torch::nn;

constexpr double kLeakySlope = 0.01;

enum class LayerKind { conv3x3, conv2x2_down, transposed_up };

struct LayerSpec {
  const char* name;
  LayerKind kind;
  int in, out;
  bool activation;  // LeakyReLU after the layer
};

// One branch: its layers in order, registered under their checkpoint names.
struct ChainImpl : nn::Module {
  explicit ChainImpl(std::vector<LayerSpec> specs) : specs_(std::move(specs)) {
    for (const auto& s : specs_) {
      if (s.kind == LayerKind::transposed_up) {
        ups_.push_back(register_module(s.name, TransposedUp2(s.in, s.out)));
        convs_.emplace_back(nullptr);
      } else {
        const int k = s.kind == LayerKind::conv3x3 ? 3 : 2;
        const auto options = nn::Conv2dOptions(s.in, s.out, k).stride(k == 3 ? 1 : 2).padding(k == 3 ? 1 : 0);
        convs_.push_back(register_module(s.name, MixedConv2d(options)));
        ups_.emplace_back(nullptr);
      }
    }
  }
  at::Tensor forward(at::Tensor x) {
    for (size_t i = 0; i < specs_.size(); ++i) {
      x = specs_[i].kind == LayerKind::transposed_up ? ups_[i]->forward(x) : convs_[i]->forward(x);
      if (specs_[i].activation) x = at::leaky_relu(x, kLeakySlope);
    }
    return x;
  }
  std::vector<LayerSpec> specs_;
  // One entry per layer in each: the layer where its kind matches, an empty holder elsewhere.
  std::vector<MixedConv2d> convs_;
  std::vector<TransposedUp2> ups_;
};
TORCH_MODULE(Chain);

constexpr LayerKind C3 = LayerKind::conv3x3, D2 = LayerKind::conv2x2_down, T2 = LayerKind::transposed_up;

// The encoder's two branches (the README of the weights, layer by layer).
const std::vector<LayerSpec> kStrided = {{"cv1", D2, 3, 16, true},  {"cv2", C3, 16, 32, true},
                                         {"cv3", D2, 32, 32, true}, {"cv4", C3, 32, 64, true},
                                         {"cv5", D2, 64, 64, true}, {"cv6", C3, 64, 4, false}};
const std::vector<LayerSpec> kPooled = {{"cv14", C3, 3, 64, true},
                                        {"cv15", C3, 64, 64, true},
                                        {"cv16", C3, 64, 64, true},
                                        {"cv17", C3, 64, 128, true},
                                        {"cv18", C3, 128, 4, false}};
// The decoder's four branches, from the full-resolution one to the latent-resolution one.
const std::vector<LayerSpec> kFull = {{"cv1", C3, 4, 8, true},    {"cv2", C3, 8, 16, true},   {"cv3", T2, 16, 16, true},
                                      {"cv4", C3, 16, 32, true},  {"cv5", C3, 32, 64, true},  {"cv6", T2, 64, 64, true},
                                      {"cv7", C3, 64, 64, true},  {"cv8", C3, 64, 64, true},  {"cv9", T2, 64, 64, true},
                                      {"cv10", C3, 64, 64, true}, {"cv11", C3, 64, 3, false}};
const std::vector<LayerSpec> kHalf = {{"c4v1", C3, 4, 8, true},   {"c4v2", C3, 8, 16, true},  {"c4v3", T2, 16, 16, true},
                                      {"c4v4", C3, 16, 32, true}, {"c4v5", C3, 32, 64, true}, {"c4v6", T2, 64, 64, true},
                                      {"c4v7", C3, 64, 64, true}, {"c4v8", C3, 64, 3, false}};
const std::vector<LayerSpec> kQuarter = {{"c3v1", C3, 4, 8, true},
                                         {"c3v2", C3, 8, 16, true},
                                         {"c3v3", T2, 16, 16, true},
                                         {"c3v4", C3, 16, 32, true},
                                         {"c3v5", C3, 32, 3, false}};
const std::vector<LayerSpec> kBase = {
    {"c2v1", C3, 4, 8, true}, {"c2v2", C3, 8, 16, true}, {"c2v3", C3, 16, 32, true}, {"c2v4", C3, 32, 3, false}};

// A module whose parameters are the union of its branches' under their own names (the checkpoints have
// no branch prefix).
struct FlatHalf : nn::Module {
  std::vector<Chain> chains;
  void add(const std::vector<LayerSpec>& specs) {
    Chain c(specs);
    for (const auto& s : specs) register_module(s.name, c->named_children()[s.name]);
    chains.push_back(c);
  }
};

at::Tensor upsample(const at::Tensor& x, int factor) {
  const double s = factor;
  return at::upsample_bilinear2d(x, {x.size(2) * factor, x.size(3) * factor}, /*align_corners=*/false, s, s);
}

const char* const kUnusedEncoderKeys[] = {"norm1.weight", "norm1.bias", "norm2.weight",
                                          "norm2.bias",   "norm3.weight", "norm3.bias"};

// The keys of one half: "<own>name" renamed to "name", "<other>name" dropped, unprefixed keys kept; the
// encoder's unused LayerNorm weights dropped. Anything else stays so that strict loading reports it.
StateDict half_keys(const StateDict& file, const std::string& own, const std::string& other, bool encoder) {
  StateDict out;
  for (const auto& item : file) {
    std::string k = item.key();
    if (k.rfind(other, 0) == 0) continue;
    if (k.rfind(own, 0) == 0) k = k.substr(own.size());
    bool unused = false;
    for (const char* u : kUnusedEncoderKeys) unused |= encoder && k == u;
    if (unused) continue;
    if (out.contains(k)) fail("vaelight: key " + k + " appears twice");
    out.insert(k, item.value());
  }
  return out;
}

}  // namespace

VaeLightAutoencoder::VaeLightAutoencoder() {
  auto enc = std::make_shared<FlatHalf>();
  enc->add(kStrided);
  enc->add(kPooled);
  auto dec = std::make_shared<FlatHalf>();
  for (const auto* b : {&kFull, &kHalf, &kQuarter, &kBase}) dec->add(*b);
  encoder_ = enc;
  decoder_ = dec;
}

VaeLightAutoencoder::VaeLightAutoencoder(const StateDict& encoder, const std::string& encoder_name,
                                         const StateDict& decoder, const std::string& decoder_name)
    : VaeLightAutoencoder() {
  StateDict enc = encoder_keys(encoder), dec = decoder_keys(decoder);
  std::string e = strict_mismatch(*encoder_, enc), d = strict_mismatch(*decoder_, dec);
  if (!e.empty() || !d.empty()) {
    fail(encoder_name == decoder_name ? encoder_name : encoder_name + " + " + decoder_name,
         "weights do not fit the vaelight architecture: " + (e.empty() ? "" : "encoder: " + e + " ") +
             (d.empty() ? "" : "decoder: " + d));
  }
  load_strict(*encoder_, enc, encoder_name + " (vaelight encoder)");
  load_strict(*decoder_, dec, decoder_name + " (vaelight decoder)");
}

VaeLightAutoencoder::~VaeLightAutoencoder() = default;

torch::nn::Module& VaeLightAutoencoder::encoder_module() { return *encoder_; }
torch::nn::Module& VaeLightAutoencoder::decoder_module() { return *decoder_; }

bool VaeLightAutoencoder::recognises(const StateDict& weights) {
  for (const auto& item : weights) {
    std::string k = item.key();
    for (const char* prefix : {"encoder.", "decoder."})
      if (k.rfind(prefix, 0) == 0) k = k.substr(std::string(prefix).size());
    if (k == "cv14.weight" || k == "c2v1.weight" || k == "c4v1.weight") return true;
  }
  return false;
}

StateDict VaeLightAutoencoder::encoder_keys(const StateDict& file) const {
  return half_keys(file, "encoder.", "decoder.", true);
}

StateDict VaeLightAutoencoder::decoder_keys(const StateDict& file) const {
  return half_keys(file, "decoder.", "encoder.", false);
}

int VaeLightAutoencoder::decoder_parameter_scale(const std::string& name) const {
  const std::string layer = name.substr(0, name.find('.'));
  for (const auto* branch : {&kFull, &kHalf, &kQuarter, &kBase}) {
    int scale = 1;
    for (const auto& s : *branch) {
      if (s.kind == LayerKind::transposed_up) scale *= 2;
      if (layer == s.name) return scale;
    }
  }
  return 1;
}

at::Tensor VaeLightAutoencoder::encode(const at::Tensor& images) {
  check_images(images);
  auto& e = static_cast<FlatHalf&>(*encoder_);
  const at::Tensor x = to_network(images * 2 - 1);
  const at::Tensor strided = e.chains[0]->forward(x);
  const at::Tensor pooled = e.chains[1]->forward(at::avg_pool2d(x, {8, 8}, {8, 8}));
  return from_network(strided + pooled);
}

at::Tensor VaeLightAutoencoder::decode_unclamped(const at::Tensor& latents) {
  check_latents(latents);
  auto& d = static_cast<FlatHalf&>(*decoder_);
  const at::Tensor z = to_network(latents);
  at::Tensor y = d.chains[0]->forward(z);
  y = y + upsample(d.chains[1]->forward(z), 2);
  y = y + upsample(d.chains[2]->forward(z), 4);
  y = y + upsample(d.chains[3]->forward(z), 8);
  return (from_network(y) + 1) * 0.5;
}

}  // namespace lrf
