#include "lrf/autoencoder/tiny_fused.h"

#include <torch/torch.h>

#include "lrf/autoencoder/conv/onednn_conv.h"
#include "lrf/autoencoder/mixed_layers.h"
#include "lrf/autoencoder/tiny_block.h"

namespace lrf {

namespace nn = torch::nn;

struct TinyFusedLayers::Entry {
  std::shared_ptr<const FusedConv2d> conv;
  std::shared_ptr<const UpsampledConv2d> upsampled;
  // What the weights were when the forms above copied them: an optimiser step or a load changes the
  // version, a change of layout (set_channels_last) the storage.
  const void* weight_data = nullptr;
  const void* bias_data = nullptr;
  int64_t weight_version = -1, bias_version = -1;
};

namespace {

// Options FusedConv2d takes: square kernel, equal strides and paddings, no dilation, one group.
bool plain_conv(const MixedConv2dImpl& conv) {
  const auto& o = conv.options;
  const auto& k = *o.kernel_size();
  const auto& s = *o.stride();
  const auto& d = *o.dilation();
  const auto& pad = *c10::get<torch::ExpandingArray<2>>(o.padding());
  return k[0] == k[1] && s[0] == s[1] && pad[0] == pad[1] && d[0] == 1 && d[1] == 1 && o.groups() == 1;
}

bool nearest_2x(const nn::UpsampleImpl& up) {
  const auto& o = up.options;
  return c10::holds_alternative<torch::enumtype::kNearest>(o.mode()) && o.scale_factor() &&
         *o.scale_factor() == std::vector<double>{2.0, 2.0};
}

}  // namespace

TinyFusedLayers::TinyFusedLayers() = default;
TinyFusedLayers::~TinyFusedLayers() = default;

TinyFusedLayers::Entry& TinyFusedLayers::current_entry(const MixedConv2dImpl& conv) {
  const at::Tensor& w = conv.weight;
  const at::Tensor& b = conv.bias;
  auto& entry = convs_[&conv];
  if (!entry) entry = std::make_unique<Entry>();
  const void* bias_data = b.defined() ? b.data_ptr() : nullptr;
  const int64_t bias_version = b.defined() ? b._version() : -1;
  if (entry->weight_data != w.data_ptr() || entry->weight_version != w._version() || entry->bias_data != bias_data ||
      entry->bias_version != bias_version) {
    *entry = Entry{};
    entry->weight_data = w.data_ptr();
    entry->weight_version = w._version();
    entry->bias_data = bias_data;
    entry->bias_version = bias_version;
  }
  return *entry;
}

std::shared_ptr<const FusedConv2d> TinyFusedLayers::fused(const MixedConv2dImpl& conv) {
  if (!plain_conv(conv)) return nullptr;
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& entry = current_entry(conv);
  if (!entry.conv) {
    const auto& o = conv.options;
    entry.conv = std::make_shared<const FusedConv2d>(conv.weight, conv.bias, static_cast<int>((*o.stride())[0]),
                                                     static_cast<int>((*c10::get<torch::ExpandingArray<2>>(o.padding()))[0]));
  }
  return entry.conv;
}

std::shared_ptr<const UpsampledConv2d> TinyFusedLayers::upsampled(const MixedConv2dImpl& conv) {
  const auto& o = conv.options;
  if (!plain_conv(conv) || (*o.kernel_size())[0] != 3 || (*o.stride())[0] != 1 ||
      (*c10::get<torch::ExpandingArray<2>>(o.padding()))[0] != 1) {
    return nullptr;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& entry = current_entry(conv);
  if (!entry.upsampled) entry.upsampled = std::make_shared<const UpsampledConv2d>(conv.weight, conv.bias);
  return entry.upsampled;
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
    } else if (const auto* up = m->as<nn::Upsample>(); up && nearest_2x(*up) && i + 1 < to) {
      if (const auto* c = layers.ptr(i + 1)->as<MixedConv2d>()) {
        if (auto conv = upsampled(*c)) {
          const bool relu = i + 2 < to && layers.ptr(i + 2)->as<nn::ReLU>() != nullptr;
          y = conv->forward(x, relu);
          i += relu ? 2 : 1;
        }
      }
    }
    if (!y.defined()) y = (layers.begin() + static_cast<std::ptrdiff_t>(i))->forward(x);
    owned = owned || !y.is_same(x);
    x = y;
  }
  return x;
}

}  // namespace lrf
