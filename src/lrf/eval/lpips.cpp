#include "lrf/eval/lpips.h"

#include <regex>
#include <set>
#include <sstream>

#include "lrf/core/error.h"
#include "lrf/eval/metrics.h"

namespace lrf {
namespace {

namespace F = torch::nn::functional;

struct ConvSpec {
  int index;  // position in torchvision's vgg16().features
  int slice;  // 1..5: the lpips slice that holds it
  int64_t in, out;
};

// VGG16's 13 conv layers. Slices end at relu1_2 (features[3]), relu2_2 (8), relu3_3 (15), relu4_3 (22),
// relu5_3 (29); slices 2–5 start with the 2×2 max pool that precedes their first conv.
const std::vector<ConvSpec>& vgg16_convs() {
  static const std::vector<ConvSpec> specs = {
      {0, 1, 3, 64},     {2, 1, 64, 64},
      {5, 2, 64, 128},   {7, 2, 128, 128},
      {10, 3, 128, 256}, {12, 3, 256, 256}, {14, 3, 256, 256},
      {17, 4, 256, 512}, {19, 4, 512, 512}, {21, 4, 512, 512},
      {24, 5, 512, 512}, {26, 5, 512, 512}, {28, 5, 512, 512}};
  return specs;
}

constexpr int64_t kLinChannels[5] = {64, 128, 256, 512, 512};
constexpr double kShift[3] = {-0.030, -0.088, -0.188};
constexpr double kScale[3] = {0.458, 0.448, 0.450};
constexpr double kNormEps = 1e-10;

std::string conv_key(const ConvSpec& c, const std::string& param) {
  return "net.slice" + std::to_string(c.slice) + "." + std::to_string(c.index) + "." + param;
}

std::string shape_string(const std::vector<int64_t>& s) {
  std::ostringstream o;
  o << "[";
  for (size_t i = 0; i < s.size(); ++i) o << (i ? ", " : "") << s[i];
  o << "]";
  return o.str();
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? ", " : "") + items[i];
  return out;
}

}  // namespace

// Maps the keys of one or more state dicts onto the canonical lpips names and collects every problem
// before failing, so that one error tells the user all that is wrong with the files.
class LpipsLoader {
 public:
  LpipsLoader() {
    for (const auto& [key, shape] : Lpips::expected_keys()) expected_[key] = shape;
  }

  void add(const TensorMap& dict, const std::string& source, bool backbone, bool lin) {
    sources_.push_back(source);
    static const std::regex torchvision_key(R"(features\.(\d+)\.(weight|bias))");
    static const std::regex lpips_key(R"(net\.slice(\d)\.(\d+)\.(weight|bias))");
    for (const auto& [key, tensor] : dict) {
      std::smatch m;
      std::string canonical;
      if (backbone && std::regex_match(key, m, torchvision_key)) {
        canonical = conv_key_for(std::stoi(m[1]), m[2]);
      } else if (backbone && std::regex_match(key, m, lpips_key)) {
        canonical = key;
      } else if (backbone && key.rfind("classifier.", 0) == 0) {
        continue;  // torchvision's fully connected head: not part of LPIPS
      } else if (lin && (key.rfind("lin", 0) == 0 || key.rfind("scaling_layer.", 0) == 0)) {
        canonical = key;
      }
      auto it = expected_.find(canonical);
      if (canonical.empty() || it == expected_.end()) {
        unexpected_.push_back(key + " (" + source + ")");
        continue;
      }
      if (!seen_.insert(canonical).second) {
        duplicated_.push_back(key + " (" + source + ")");
        continue;
      }
      std::vector<int64_t> shape(tensor.sizes().begin(), tensor.sizes().end());
      if (!tensor.defined() || !tensor.is_floating_point() || shape != it->second) {
        std::string got = !tensor.defined()         ? "undefined"
                          : !tensor.is_floating_point() ? "non-float " + shape_string(shape)
                                                        : shape_string(shape);
        misshaped_.push_back(key + " (" + source + "): " + got + ", expected " + shape_string(it->second));
        continue;
      }
      found_[canonical] = tensor.detach().to(torch::kCPU, torch::kFloat32).contiguous();
    }
  }

  Lpips finish() {
    std::vector<std::string> missing;
    for (const auto& [key, shape] : expected_) {
      bool optional = key.rfind("scaling_layer.", 0) == 0;
      if (!seen_.count(key) && !optional) missing.push_back(key);
    }
    std::vector<std::string> problems;
    if (!missing.empty()) problems.push_back("missing keys: " + join(missing));
    if (!unexpected_.empty()) problems.push_back("unexpected keys: " + join(unexpected_));
    if (!duplicated_.empty()) problems.push_back("keys given twice: " + join(duplicated_));
    if (!misshaped_.empty()) problems.push_back("wrong shapes: " + join(misshaped_));
    check_scaling("scaling_layer.shift", kShift, problems);
    check_scaling("scaling_layer.scale", kScale, problems);
    if (!problems.empty()) {
      std::string what = "not LPIPS v0.1 VGG16 weights: ";
      for (size_t i = 0; i < problems.size(); ++i) what += (i ? "; " : "") + problems[i];
      fail(join(sources_), what);
    }
    Lpips net;
    for (const auto& c : vgg16_convs()) {
      net.convs_.push_back({c.index, found_.at(conv_key(c, "weight")), found_.at(conv_key(c, "bias"))});
    }
    for (int k = 0; k < 5; ++k) net.lin_.push_back(found_.at("lin" + std::to_string(k) + ".model.1.weight"));
    net.shift_ = torch::tensor({kShift[0], kShift[1], kShift[2]}, torch::kFloat32).view({1, 3, 1, 1});
    net.scale_ = torch::tensor({kScale[0], kScale[1], kScale[2]}, torch::kFloat32).view({1, 3, 1, 1});
    return net;
  }

 private:
  // features.N.* → net.sliceK.N.*; an index that is not a conv layer maps to "" (unexpected).
  static std::string conv_key_for(int index, const std::string& param) {
    for (const auto& c : vgg16_convs()) {
      if (c.index == index) return conv_key(c, param);
    }
    return "";
  }

  // The scaling constants are fixed in LPIPS v0.1; a file carrying other values is not that network.
  void check_scaling(const std::string& key, const double (&values)[3], std::vector<std::string>& problems) {
    auto it = found_.find(key);
    if (it == found_.end()) return;
    auto expected = torch::tensor({values[0], values[1], values[2]}, torch::kFloat32).view({1, 3, 1, 1});
    if (!torch::allclose(it->second, expected, 0.0, 1e-6)) {
      problems.push_back(key + " differs from LPIPS v0.1's constants");
    }
  }

  std::map<std::string, std::vector<int64_t>> expected_;
  std::map<std::string, torch::Tensor> found_;  // valid tensors by canonical key
  std::set<std::string> seen_;                   // canonical keys given at all (valid or not)
  std::vector<std::string> sources_, unexpected_, duplicated_, misshaped_;
};

std::vector<std::pair<std::string, std::vector<int64_t>>> Lpips::expected_keys() {
  std::vector<std::pair<std::string, std::vector<int64_t>>> keys;
  for (const auto& c : vgg16_convs()) {
    keys.push_back({conv_key(c, "weight"), {c.out, c.in, 3, 3}});
    keys.push_back({conv_key(c, "bias"), {c.out}});
  }
  for (int k = 0; k < 5; ++k) keys.push_back({"lin" + std::to_string(k) + ".model.1.weight", {1, kLinChannels[k], 1, 1}});
  keys.push_back({"scaling_layer.shift", {1, 3, 1, 1}});
  keys.push_back({"scaling_layer.scale", {1, 3, 1, 1}});
  return keys;
}

Lpips Lpips::from_state_dict(const TensorMap& combined, const std::string& source) {
  LpipsLoader loader;
  loader.add(combined, source, true, true);
  return loader.finish();
}

Lpips Lpips::from_state_dicts(const TensorMap& lin, const TensorMap& backbone, const std::string& lin_source,
                              const std::string& backbone_source) {
  LpipsLoader loader;
  loader.add(lin, lin_source, false, true);
  loader.add(backbone, backbone_source, true, false);
  return loader.finish();
}

std::vector<double> Lpips::layer_distances(const torch::Tensor& a, const torch::Tensor& b) const {
  std::ostringstream shapes;
  shapes << a.sizes() << " and " << b.sizes();
  if (!a.defined() || !b.defined() || a.sizes() != b.sizes() || a.dim() != 3 || a.size(0) != 3) {
    fail("lpips: expected two RGB images of the same [3, H, W] shape, got " + shapes.str());
  }
  if (a.size(1) < 16 || a.size(2) < 16) fail("lpips: images must be at least 16×16, got " + shapes.str());
  torch::NoGradGuard no_grad;
  // The two images go through the network side by side, one slice at a time, so that only the current
  // slice's activations are alive: full-resolution evaluation images need hundreds of MB per activation.
  auto prepare = [&](const torch::Tensor& img) {
    auto x = img.to(torch::kCPU, torch::kFloat32).clamp(0.0, 1.0).unsqueeze(0) * 2.0 - 1.0;
    return (x - shift_) / scale_;
  };
  auto normalize = [](const torch::Tensor& f) {
    return f / (f.pow(2).sum(1, true).sqrt() + kNormEps);
  };
  torch::Tensor x0 = prepare(a), x1 = prepare(b);
  std::vector<double> out;
  size_t next = 0;
  for (int slice = 1; slice <= 5; ++slice) {
    if (slice > 1) {
      x0 = F::max_pool2d(x0, F::MaxPool2dFuncOptions(2).stride(2));
      x1 = F::max_pool2d(x1, F::MaxPool2dFuncOptions(2).stride(2));
    }
    for (; next < convs_.size() && vgg16_convs()[next].slice == slice; ++next) {
      const auto& c = convs_[next];
      auto opts = F::Conv2dFuncOptions().bias(c.bias).padding(1);
      x0 = torch::relu(F::conv2d(x0, c.weight, opts));
      x1 = torch::relu(F::conv2d(x1, c.weight, opts));
    }
    auto diff = (normalize(x0) - normalize(x1)).pow(2);
    auto weighted = F::conv2d(diff, lin_[slice - 1]);  // 1×1, no bias: [1, 1, h, w]
    out.push_back(weighted.mean().item<double>());
  }
  return out;
}

double Lpips::distance(const torch::Tensor& a, const torch::Tensor& b) const {
  double sum = 0.0;
  for (double d : layer_distances(a, b)) sum += d;
  return sum;
}

double Lpips::distance(const cv::Mat& a, const cv::Mat& b) const {
  return distance(image_to_chw(a), image_to_chw(b));
}

}  // namespace lrf
