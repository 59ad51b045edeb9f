#pragma once
// Inference through the tiny autoencoder's layers with each convolution's residual add and ReLU done as
// it stores its outputs (FusedConv2d, onednn_conv.h) instead of one pass over memory each.
#include <cstddef>
#include <memory>
#include <mutex>
#include <unordered_map>

#include <ATen/core/Tensor.h>
#include <torch/nn/modules/container/sequential.h>

namespace lrf {

class FusedConv2d;
class MixedConv2dImpl;
class UpsampledConv2d;
struct TinyBlockImpl;

class TinyFusedLayers {
 public:
  TinyFusedLayers();
  ~TinyFusedLayers();

  // Layers [from, to) of `layers` (a tiny autoencoder's encoder or decoder) applied to x, a bf16 or
  // float32 tensor in channels-last layout; for inference only (nothing is recorded for autograd). Each
  // convolution, with the ReLU that follows it, and each residual block's three convolutions, add and
  // ReLU run fused, and so does a 2x nearest upsampling with the convolution after it (UpsampledConv2d);
  // other layers (the soft clamp, the group-norm branch) run their modules.
  // The value is the modules' up to the order of float32 sums inside the convolutions, and in bf16 one
  // rounding fewer per block (the residual is added before the output is rounded) and weights rounded
  // after being summed in an upsampled convolution. x is not modified.
  // A layer's weights are read when first met and again whenever they change (fine-tuning).
  at::Tensor run(torch::nn::SequentialImpl& layers, size_t from, size_t to, at::Tensor x);

 private:
  // The fused form of `conv`, or null when its options are not ones FusedConv2d takes.
  std::shared_ptr<const FusedConv2d> fused(const MixedConv2dImpl& conv);
  // The fused form of a 2x nearest upsampling followed by `conv` (a 3x3, padding 1, stride 1), or null.
  std::shared_ptr<const UpsampledConv2d> upsampled(const MixedConv2dImpl& conv);
  struct Entry;
  // The cache entry of `conv`, emptied if its weights changed since it was filled (mutex_ held).
  Entry& current_entry(const MixedConv2dImpl& conv);
  // relu(conv(x) + x) for a block whose convolutions all fuse; `owned`: x may be overwritten.
  at::Tensor block(TinyBlockImpl& block, at::Tensor x, bool owned);

  std::mutex mutex_;
  std::unordered_map<const MixedConv2dImpl*, std::unique_ptr<Entry>> convs_;
};

}  // namespace lrf
