#include "lrf/autoencoder/tiny_fused.h"

#include <torch/torch.h>

#include "lrf/autoencoder/mixed_layers.h"
#include "lrf/autoencoder/onednn_conv.h"
#include "lrf/autoencoder/tiny_block.h"

namespace lrf {

namespace nn = torch::nn;

struct TinyFusedLayers::Entry {
  std::shared_ptr<const FusedConv2d> conv;
  // What the weights were when `conv` copied them: an optimiser step or a load changes the version, a
  // change of layout (set_channels_last) the storage.
  const void* weight_data = nullptr;
  const void* bias_data = nullptr;
  int64_t weight_version = -1, bias_version = -1;
};

TinyFusedLayers::TinyFusedLayers() = default;
TinyFusedLayers::~TinyFusedLayers() = default;

std::shared_ptr<const FusedConv2d> TinyFusedLayers::fused(const MixedConv2dImpl& conv) {
  const auto& o = conv.options;
  const auto& k = *o.kernel_size();
  const auto& s = *o.stride();
  const auto& d = *o.dilation();
  const auto& pad = *c10::get<torch::ExpandingArray<2>>(o.padding());
  if (k[0] != k[1] || s[0] != s[1] || pad[0] != pad[1] || d[0] != 1 || d[1] != 1 || o.groups() != 1) return nullptr;
  const at::Tensor& w = conv.weight;
  const at::Tensor& b = conv.bias;
  std::lock_guard<std::mutex> lock(mutex_);
  auto& entry = convs_[&conv];
  if (!entry) entry = std::make_unique<Entry>();
  const void* bias_data = b.defined() ? b.data_ptr() : nullptr;
  const int64_t bias_version = b.defined() ? b._version() : -1;
  if (!entry->conv || entry->weight_data != w.data_ptr() || entry->weight_version != w._version() ||
      entry->bias_data != bias_data || entry->bias_version != bias_version) {
    entry->conv = std::make_shared<const FusedConv2d>(w, b, static_cast<int>(s[0]), static_cast<int>(pad[0]));
    entry->weight_data = w.data_ptr();
    entry->weight_version = w._version();
    entry->bias_data = bias_data;
    entry->bias_version = bias_version;
  }
  return entry->conv;
}

at::Tensor TinyFusedLayers::block(TinyBlockImpl& b, at::Tensor x, bool owned) {
  if (b.conv->size() != 5) return {};
  std::shared_ptr<const FusedConv2d> convs[3];
  for (int k = 0; k < 3; ++k) {
    const auto* c = b.conv->ptr(2 * k)->as<MixedConv2d>();
    if (!c || !(convs[k] = fused(*c))) return {};
  }
  if (b.pool) {
    x = x + b.pool->forward(x);
    owned = true;
  }
  // The last convolution adds its result into x, so x must be a channels-last tensor of our own.
  if (!owned || !x.is_contiguous(at::MemoryFormat::ChannelsLast)) x = x.clone(at::MemoryFormat::ChannelsLast);
  at::Tensor h = convs[0]->forward(x, /*relu=*/true);
  h = convs[1]->forward(h, /*relu=*/true);
  return convs[2]->forward(h, /*relu=*/true, /*residual=*/x);
}

at::Tensor TinyFusedLayers::run(nn::SequentialImpl& layers, size_t from, size_t to, at::Tensor x) {
  torch::NoGradGuard no_grad;
  bool owned = false;  // x is the caller's until a layer has produced a new tensor
  for (size_t i = from; i < to; ++i) {
    const auto& m = layers.ptr(i);
    at::Tensor y;
    if (const auto* c = m->as<MixedConv2d>()) {
      if (auto conv = fused(*c)) {
        const bool relu = i + 1 < to && layers.ptr(i + 1)->as<nn::ReLU>() != nullptr;
        y = conv->forward(x, relu);
        if (relu) ++i;
      }
    } else if (auto* b = m->as<TinyBlock>()) {
      y = block(*b, x, owned);
    }
    if (!y.defined()) y = (layers.begin() + static_cast<std::ptrdiff_t>(i))->forward(x);
    owned = owned || !y.is_same(x);
    x = y;
  }
  return x;
}

}  // namespace lrf
