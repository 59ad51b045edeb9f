#include "lrf/detail/blend_network.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include <torch/torch.h>

#include "lrf/core/error.h"
#include "lrf/core/log.h"
#include "lrf/eval/metrics.h"

namespace lrf::detail {
namespace {

// The hand-made blend's largest finite weight, used as its base when the decoded view alone was chosen.
constexpr double kLargestBaseWeight = 8.0;

// What the network sees of one view, and what it mixes.
struct BlendInputs {
  torch::Tensor features;    // [3 + 5K, H, W]: decoded RGB; per photograph its RGB, validity and trust
  torch::Tensor base;        // [K + 1, H, W]: the hand-made blend's log-weights, decoded first
  torch::Tensor candidates;  // [K + 1, 3, H, W]: the decoded view, then each photograph
};

BlendInputs inputs_of(const cv::Mat& decoded, const std::vector<WarpedView>& warped, const DetailOptions& options) {
  const int K = options.views, H = decoded.rows, W = decoded.cols;
  if (static_cast<int>(warped.size()) > K) fail("BlendNetwork: more photographs than --detail-views");
  const std::vector<cv::Mat> trusts = photograph_trusts(decoded, warped, options);
  const double own = std::isfinite(options.decoded_weight) ? options.decoded_weight : kLargestBaseWeight;
  BlendInputs in;
  in.features = torch::zeros({3 + 5 * K, H, W}, torch::kFloat32);
  in.base = torch::full({K + 1, H, W}, std::log(1e-6), torch::kFloat32);
  in.candidates = torch::zeros({K + 1, 3, H, W}, torch::kFloat32);
  const torch::Tensor d = image_to_chw(decoded);
  in.features.narrow(0, 0, 3).copy_(d);
  in.base[0].fill_(std::log(own));
  in.candidates[0].copy_(d);
  for (size_t k = 0; k < warped.size(); ++k) {
    const int64_t at = 3 + 5 * static_cast<int64_t>(k);
    const torch::Tensor c = image_to_chw(warped[k].image), valid = image_to_chw(warped[k].valid), trust = image_to_chw(trusts[k]);
    in.features.narrow(0, at, 3).copy_(c);
    in.features.narrow(0, at + 3, 1).copy_(valid);
    in.features.narrow(0, at + 4, 1).copy_(trust);
    in.base[static_cast<int64_t>(k) + 1].copy_(torch::log(trust[0] + 1e-6));
    in.candidates[static_cast<int64_t>(k) + 1].copy_(c);
  }
  return in;
}

struct Net : torch::nn::Module {
  Net(int in, int width, int out)
      : a(register_module("a", torch::nn::Conv2d(torch::nn::Conv2dOptions(in, width, 3).padding(1)))),
        b(register_module("b", torch::nn::Conv2d(torch::nn::Conv2dOptions(width, width, 3).padding(1)))),
        c(register_module("c", torch::nn::Conv2d(torch::nn::Conv2dOptions(width, out, 3).padding(1)))) {
    // Zero: the network starts as the hand-made blend.
    torch::NoGradGuard no_grad;
    c->weight.zero_();
    c->bias.zero_();
  }
  // features [B, 3 + 5K, H, W], base [B, K + 1, H, W], candidates [B, K + 1, 3, H, W] -> [B, 3, H, W]
  torch::Tensor forward(const torch::Tensor& features, const torch::Tensor& base, const torch::Tensor& candidates) {
    const torch::Tensor logits = base + c(torch::relu(b(torch::relu(a(features)))));
    return (torch::softmax(logits, 1).unsqueeze(2) * candidates).sum(1);
  }
  torch::nn::Conv2d a, b, c;
};


}  // namespace

struct BlendNetwork::Impl {
  DetailOptions options;
  std::shared_ptr<Net> net;
};

BlendNetwork::BlendNetwork(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
BlendNetwork::~BlendNetwork() = default;

std::unique_ptr<BlendNetwork> BlendNetwork::learn(const std::vector<CalibrationSample>& samples,
                                                  const DetailOptions& options, const BlendNetworkOptions& network,
                                                  BlendNetworkReport* report) {
  const auto t0 = std::chrono::steady_clock::now();
  BlendNetworkReport r;
  if (samples.size() < 4) {
    if (report) *report = r;
    return nullptr;
  }
  torch::manual_seed(network.seed);
  std::vector<BlendInputs> inputs;
  std::vector<torch::Tensor> photos;
  std::vector<size_t> learn_on, held_out;
  for (size_t i = 0; i < samples.size(); ++i) {
    if (samples[i].photo.size() != samples[i].decoded.size() || samples[i].photo.type() != CV_32FC3)
      fail("BlendNetwork: a training view's photograph and decoded frame differ in size or type");
    inputs.push_back(inputs_of(samples[i].decoded, samples[i].warped, options));
    photos.push_back(image_to_chw(samples[i].photo));
    (i % 4 == 3 ? held_out : learn_on).push_back(i);
  }
  r.learned_on = static_cast<int>(learn_on.size());
  r.held_out = static_cast<int>(held_out.size());

  auto net = std::make_shared<Net>(3 + 5 * options.views, network.width, options.views + 1);
  torch::optim::Adam adam(net->parameters(), torch::optim::AdamOptions(network.lr));
  std::mt19937_64 rng(network.seed);
  // One crop size for every view, so that crops of views of different sizes stack.
  int64_t side_y = network.crop, side_x = network.crop;
  for (size_t i : learn_on) side_y = std::min(side_y, photos[i].size(1)), side_x = std::min(side_x, photos[i].size(2));
  for (int step = 0; step < network.steps; ++step) {
    std::vector<torch::Tensor> f, b, c, p;
    for (int k = 0; k < network.batch; ++k) {
      const size_t i = learn_on[rng() % learn_on.size()];
      const int64_t H = photos[i].size(1), W = photos[i].size(2);
      const int64_t y = static_cast<int64_t>(rng() % static_cast<uint64_t>(H - side_y + 1));
      const int64_t x = static_cast<int64_t>(rng() % static_cast<uint64_t>(W - side_x + 1));
      auto crop = [&](const torch::Tensor& t) { return t.narrow(-2, y, side_y).narrow(-1, x, side_x); };
      f.push_back(crop(inputs[i].features));
      b.push_back(crop(inputs[i].base));
      c.push_back(crop(inputs[i].candidates));
      p.push_back(crop(photos[i]));
    }
    const torch::Tensor out = net->forward(torch::stack(f), torch::stack(b), torch::stack(c));
    const torch::Tensor loss = torch::mse_loss(out, torch::stack(p));
    adam.zero_grad();
    loss.backward();
    adam.step();
  }

  // Judged on the held-out training views, whole, against the hand-made blend it started from.
  torch::NoGradGuard no_grad;
  double learned = 0, handmade = 0, values = 0;
  for (size_t i : held_out) {
    const torch::Tensor out = net->forward(inputs[i].features.unsqueeze(0), inputs[i].base.unsqueeze(0),
                                           inputs[i].candidates.unsqueeze(0))[0].clamp(0, 1);
    learned += (out - photos[i]).pow(2).sum().item<double>();
    const cv::Mat baseline = std::isfinite(options.decoded_weight)
                                 ? blend_detail(samples[i].decoded, samples[i].warped, options)
                                 : samples[i].decoded;
    handmade += (image_to_chw(baseline) - photos[i]).pow(2).sum().item<double>();
    values += static_cast<double>(photos[i].numel());
  }
  r.learned_psnr = psnr_from_mse(learned / values);
  r.handmade_psnr = psnr_from_mse(handmade / values);
  r.used = learned < handmade;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (report) *report = r;
  if (!r.used) return nullptr;
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->net = net;
  return std::unique_ptr<BlendNetwork>(new BlendNetwork(std::move(impl)));
}

cv::Mat BlendNetwork::blend(const cv::Mat& decoded, const std::vector<WarpedView>& warped) const {
  torch::NoGradGuard no_grad;
  const BlendInputs in = inputs_of(decoded, warped, impl_->options);
  const torch::Tensor out = impl_->net->forward(in.features.unsqueeze(0), in.base.unsqueeze(0),
                                                in.candidates.unsqueeze(0))[0]
                                .clamp(0, 1)
                                .permute({1, 2, 0})
                                .contiguous();
  return cv::Mat(decoded.rows, decoded.cols, CV_32FC3, out.data_ptr<float>()).clone();
}

}  // namespace lrf::detail
