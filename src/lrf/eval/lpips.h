#pragma once
// LPIPS v0.1 with the VGG16 backbone, computed as the `lpips` Python package computes it
// (lpips.LPIPS(net='vgg', version='0.1') in eval mode):
//   x in [-1, 1] → (x − shift) / scale, shift = [−.030, −.088, −.188], scale = [.458, .448, .450]
//   → VGG16 `features` sliced after relu1_2, relu2_2, relu3_3, relu4_3, relu5_3
//   → each slice's output unit-normalised over channels (x / (‖x‖ + 1e-10))
//   → squared difference of the two images' features → 1×1 `lin` conv (no bias) → spatial mean
//   → sum over the five layers.
// Weights are a state dict. Accepted key layouts:
//   - the `lpips` package's: net.slice1.0.weight … net.slice5.28.bias (backbone, with torchvision's layer
//     indices), lin0.model.1.weight … lin4.model.1.weight, and optionally scaling_layer.shift/scale
//     (buffers that LPIPS().state_dict() includes; they must hold the constants above);
//   - torchvision's vgg16 for the backbone: features.0.weight … features.28.bias (its classifier.* keys
//     are ignored, so the whole torchvision file can be given).
// Loading is strict: missing, unexpected, duplicated or mis-shaped keys give one error listing them all.
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <torch/torch.h>

namespace lrf {

// Weights by parameter name. (Not named StateDict: core's loader has its own ordered StateDict type;
// tensor_map() converts it.)
using TensorMap = std::map<std::string, torch::Tensor>;

// A TensorMap of any state dict whose items have key() and value(), such as torch::OrderedDict (what
// lrf::load_state_dict returns).
template <typename OrderedDictLike>
TensorMap tensor_map(const OrderedDictLike& dict) {
  TensorMap out;
  for (const auto& item : dict) out[item.key()] = item.value();
  return out;
}

class Lpips {
 public:
  // One state dict with backbone and lin weights (the lpips layout, or torchvision backbone keys).
  // `source` names the weights in errors (usually the file path).
  static Lpips from_state_dict(const TensorMap& combined, const std::string& source = "LPIPS weights");
  // The lin weights (e.g. the lpips package's weights/v0.1/vgg.pth) and the backbone (e.g. torchvision's
  // vgg16 file) from separate state dicts.
  static Lpips from_state_dicts(const TensorMap& lin, const TensorMap& backbone,
                                const std::string& lin_source = "LPIPS lin weights",
                                const std::string& backbone_source = "VGG16 weights");

  // Distance between two RGB images in [0, 1] (clamped to it, as renders are clamped before scoring),
  // [3, H, W] with H, W >= 16 (the last slice runs at 1/16 of the size). 0 for identical images.
  double distance(const torch::Tensor& a, const torch::Tensor& b) const;
  double distance(const cv::Mat& a, const cv::Mat& b) const;
  // The five per-layer terms whose sum is distance() (for diagnostics and tests).
  std::vector<double> layer_distances(const torch::Tensor& a, const torch::Tensor& b) const;

  // The canonical (lpips package) key names and shapes of a complete state dict; for writing test weights.
  static std::vector<std::pair<std::string, std::vector<int64_t>>> expected_keys();

 private:
  Lpips() = default;
  // One VGG16 conv layer: torchvision's index in `features` (0, 2, 5, …, 28) and its weights.
  struct Conv {
    int index;
    torch::Tensor weight, bias;
  };
  std::vector<Conv> convs_;       // 13 layers
  std::vector<torch::Tensor> lin_;  // 5 × [1, C, 1, 1]
  torch::Tensor shift_, scale_;     // [1, 3, 1, 1]
  friend class LpipsLoader;
};

}  // namespace lrf
